// The 3-D view: renderer, camera and map controls, the point materials (colour by height or
// intensity, tinted for the diff), on-demand rendering, and what the tests read back (frame rate,
// whether the canvas shows anything).
//
// The scene is in the map's ENU frame, metres, z up, but relative to a local origin near the map's
// centre (View.local): ENU coordinates are large (a map's tiles can lie kilometres from its origin)
// and WebGL computes in float32, which would make points jitter by centimetres there. Each tile is
// placed at (its origin - local), both in float64 here, and its points are small float32 offsets
// from its origin, as the tile codec stores them.
import * as THREE from 'three';
import { MapControls } from 'three/addons/controls/MapControls.js';

export const BACKGROUND = 0x14181d;

const vertexShader = /* glsl */ `
attribute float intensity;
uniform float pointSize;
uniform int colourBy;      // 0: height, 1: intensity
uniform vec2 heightRange;  // metres (ENU up) that span the colour ramp
uniform float localZ;      // the local origin's height: the scene is relative to it
uniform vec3 tint;
uniform float tintMix;     // 0: the ramp's colour, 1: the tint
varying vec3 vColour;

// Height: dark blue through cyan, green and yellow to red, evenly spaced.
vec3 heightRamp(float t) {
  vec3 c0 = vec3(0.17, 0.20, 0.58), c1 = vec3(0.11, 0.62, 0.86), c2 = vec3(0.33, 0.80, 0.38);
  vec3 c3 = vec3(0.96, 0.84, 0.22), c4 = vec3(0.90, 0.27, 0.16);
  float s = clamp(t, 0.0, 1.0) * 4.0;
  if (s < 1.0) return mix(c0, c1, s);
  if (s < 2.0) return mix(c1, c2, s - 1.0);
  if (s < 3.0) return mix(c2, c3, s - 2.0);
  return mix(c3, c4, s - 3.0);
}

// Intensity: a warm grey ramp, brighter for stronger returns (LiDAR intensity reads like a photo).
vec3 intensityRamp(float t) {
  float s = pow(clamp(t, 0.0, 1.0), 0.6);
  return mix(vec3(0.10, 0.10, 0.16), vec3(1.0, 0.96, 0.86), s);
}

void main() {
  vec4 world = modelMatrix * vec4(position, 1.0);
  float h = (world.z + localZ - heightRange.x) / max(heightRange.y - heightRange.x, 0.01);
  vec3 c = colourBy == 0 ? heightRamp(h) : intensityRamp(intensity);
  vColour = mix(c, tint, tintMix);
  gl_Position = projectionMatrix * viewMatrix * world;
  gl_PointSize = pointSize;
}`;

const fragmentShader = /* glsl */ `
varying vec3 vColour;
void main() { gl_FragColor = vec4(vColour, 1.0); }`;

// How a tile is drawn: the ramp, or tinted (the diff: added, removed, changed; unchanged tiles and
// the heat map's context greyed).
export const KINDS = {
  base: { tint: 0x000000, mix: 0 },
  added: { tint: 0x35d07f, mix: 0.8 },
  removed: { tint: 0xff4b4b, mix: 0.8 },
  changed: { tint: 0xffa51f, mix: 0.8 },
  same: { tint: 0x6b717c, mix: 0.78 },
  context: { tint: 0x6b717c, mix: 0.7 },
};

export class View {
  constructor(canvas) {
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: false, powerPreference: 'high-performance' });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.renderer.setClearColor(BACKGROUND, 1);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(50, 1, 0.5, 60000);
    this.camera.up.set(0, 0, 1);  // ENU: z up
    this.controls = new MapControls(this.camera, canvas);
    this.controls.maxPolarAngle = THREE.MathUtils.degToRad(80);
    this.controls.zoomToCursor = true;
    this.local = new THREE.Vector3();  // the ENU point at the scene's origin (float64 here)
    const dpr = window.devicePixelRatio || 1;
    // Uniforms shared by every point material: one switch recolours the whole map.
    this.shared = {
      pointSize: { value: 2 * dpr },
      colourBy: { value: 0 },
      heightRange: { value: new THREE.Vector2(0, 10) },
      localZ: { value: 0 },
    };
    this.overviewSize = { value: 3 * dpr };
    this.materials = new Map();
    this.frames = 0;
    this.pending = false;
    this.continuous = false;
    this.onFrame = [];  // callbacks before each render (vehicle marker sizes)
    this.afterFrame = [];  // and after it (first-render times)
    this.resize();
    new ResizeObserver(() => { this.resize(); this.render(); }).observe(canvas);
    this.controls.addEventListener('change', () => this.render());
  }

  resize() {
    const w = this.canvas.clientWidth || 1, h = this.canvas.clientHeight || 1;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
  }

  // One material per kind (and one for the overview), sharing the colour uniforms.
  material(kind, overview = false) {
    const key = `${kind}${overview ? '/overview' : ''}`;
    let m = this.materials.get(key);
    if (!m) {
      const k = KINDS[kind];
      m = new THREE.ShaderMaterial({
        vertexShader,
        fragmentShader,
        uniforms: {
          ...this.shared,
          pointSize: overview ? this.overviewSize : this.shared.pointSize,
          // The shader writes its colours as they are (no colour management): the tint too.
          tint: { value: new THREE.Color().setHex(k.tint, THREE.LinearSRGBColorSpace) },
          tintMix: { value: k.mix },
        },
      });
      this.materials.set(key, m);
    }
    return m;
  }

  setLocal(x, y, z) {
    this.local.set(x, y, z);
    this.shared.localZ.value = z;
  }

  // ENU -> scene coordinates, and back.
  toScene(x, y, z = this.local.z) { return new THREE.Vector3(x - this.local.x, y - this.local.y, z - this.local.z); }
  centre() {
    const t = this.controls.target;
    return { x: t.x + this.local.x, y: t.y + this.local.y };
  }
  // The radius of ground the view shows around its centre, metres (the ROI to ask for).
  radius() {
    const d = this.camera.position.distanceTo(this.controls.target);
    const half = Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2)) * d;
    return half * Math.max(1, this.camera.aspect) * 1.15;
  }
  // Looks at (x, y) ENU from above, slightly tilted, showing `radius` metres around it.
  lookAt(x, y, radius, groundZ = this.local.z) {
    const half = radius / 1.15 / Math.max(1, this.camera.aspect);
    const d = half / Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2));
    const target = this.toScene(x, y, groundZ);
    this.controls.target.copy(target);
    const tilt = THREE.MathUtils.degToRad(20);
    this.camera.position.set(target.x, target.y - d * Math.sin(tilt), target.z + d * Math.cos(tilt));
    this.camera.lookAt(target);
    this.controls.update();
    this.render();
  }

  // Renders at the next animation frame (once however many ask).
  render() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => this.frame());
  }

  frame() {
    this.pending = false;
    for (const f of this.onFrame) f();
    this.renderer.render(this.scene, this.camera);
    this.frames++;
    for (const f of this.afterFrame) f();
    if (this.continuous) this.render();
  }

  // Frames per second while the view turns about its centre, rendering every animation frame for
  // `seconds`: the scene as it stands is drawn anew each frame. The camera is put back afterwards.
  async measureFps(seconds = 5) {
    const position = this.camera.position.clone();
    const target = this.controls.target.clone();
    const offset = position.clone().sub(target);
    const started = performance.now();
    const frames0 = this.frames;
    const turn = () => {
      const a = ((performance.now() - started) / 1000) * 0.3;  // radians
      const o = offset.clone().applyAxisAngle(new THREE.Vector3(0, 0, 1), a);
      this.camera.position.copy(target).add(o);
      this.camera.lookAt(target);
    };
    this.onFrame.push(turn);
    this.continuous = true;
    this.render();
    await new Promise((resolve) => setTimeout(resolve, seconds * 1000));
    this.continuous = false;
    this.onFrame.splice(this.onFrame.indexOf(turn), 1);
    const elapsed = (performance.now() - started) / 1000;
    const frames = this.frames - frames0;
    this.camera.position.copy(position);
    this.camera.lookAt(target);
    this.controls.update();
    this.render();
    return { fps: frames / elapsed, frames, seconds: elapsed };
  }

  // What the canvas shows, rendered now and read back in the same task (the drawing buffer is still
  // the frame's then, without preserveDrawingBuffer): its size, how many pixels differ from the
  // background, and how many distinct colours (coarsely) there are.
  canvasStats() {
    this.renderer.render(this.scene, this.camera);
    const gl = this.renderer.getContext();
    const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
    const px = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    const br = (BACKGROUND >> 16) & 255, bgG = (BACKGROUND >> 8) & 255, bb = BACKGROUND & 255;  // cleared as given (sRGB)
    let drawn = 0;
    const colours = new Set();
    for (let i = 0; i < px.length; i += 4) {
      if (Math.abs(px[i] - br) + Math.abs(px[i + 1] - bgG) + Math.abs(px[i + 2] - bb) > 12) {
        drawn++;
        colours.add(((px[i] >> 4) << 8) | ((px[i + 1] >> 4) << 4) | (px[i + 2] >> 4));
      }
    }
    return { width: w, height: h, drawn, fraction: drawn / (w * h), colours: colours.size };
  }
}
