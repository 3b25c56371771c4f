// pointatlas report viewer: three.js scenes for the 3-D views of a report.
//
// The report (src/pointatlas/viz/_report.py) writes, for every view, a
// <div class="pa-view"> holding a <script type="application/json"> with the
// view's data: points as base64 float32 positions, per-field base64 values
// (float32 for scalars, int32 for labels) with a colour table each, the
// original index of every shown point (uint32) and meshes as base64 float32
// vertices and uint32 triangles. This script builds one viewer per view with
// rotate/zoom (OrbitControls), a field switch, a legend and click-to-pick.
// When every view has drawn its first frame it sets window.pointatlasReady.
//
// Built by build.sh into src/pointatlas/viz/assets/viewer.min.js (esbuild,
// tree-shaken, IIFE); nothing is fetched at run time.

import {
  AmbientLight,
  BufferAttribute,
  BufferGeometry,
  Color,
  DirectionalLight,
  DoubleSide,
  LinearSRGBColorSpace,
  Mesh,
  MeshLambertMaterial,
  PerspectiveCamera,
  Points,
  PointsMaterial,
  Raycaster,
  Scene,
  Sphere,
  Vector2,
  Vector3,
  WebGLRenderer,
} from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";

const PICK_RADIUS_PX = 6;

function decode(b64, Type) {
  const bin = atob(b64);
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
  return new Type(bytes.buffer);
}

function el(tag, attrs, text) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) node.setAttribute(k, v);
  if (text !== undefined) node.textContent = text;
  return node;
}

function formatValue(v, kind) {
  if (kind === "labels") return String(v);
  if (Number.isNaN(v)) return "NaN";
  return Number(v).toPrecision(6).replace(/\.?0+(e|$)/, "$1");
}

// Per-point colours (uint8 RGB) of a field: labels through their palette,
// scalars through the 256-entry colormap table over [vmin, vmax]; NaN grey.
function colorsOf(f) {
  const n = f.values.length;
  const out = new Uint8Array(3 * n);
  const cm = f.colormap;
  if (f.kind === "labels") {
    const ids = decode(cm.labels, Int32Array);
    const rgb = decode(cm.colors, Uint8Array);
    const index = new Map();
    for (let i = 0; i < ids.length; i++) index.set(ids[i], i);
    for (let k = 0; k < n; k++) {
      const i = index.get(f.values[k]);
      for (let a = 0; a < 3; a++) out[3 * k + a] = i === undefined ? cm.missing[a] : rgb[3 * i + a];
    }
    return out;
  }
  const lut = decode(cm.lut, Uint8Array);
  const levels = lut.length / 3;
  const span = cm.vmax - cm.vmin;
  for (let k = 0; k < n; k++) {
    const v = f.values[k];
    if (Number.isNaN(v)) {
      for (let a = 0; a < 3; a++) out[3 * k + a] = cm.missing[a];
      continue;
    }
    let t = span > 0 ? (v - cm.vmin) / span : 0.5;
    t = Math.min(1, Math.max(0, t));
    const i = Math.min(levels - 1, Math.floor(t * levels));
    for (let a = 0; a < 3; a++) out[3 * k + a] = lut[3 * i + a];
  }
  return out;
}

class View {
  constructor(root, data) {
    this.root = root;
    this.data = data;
    this.canvasBox = root.querySelector(".pa-canvas");
    this.legend = root.querySelector(".pa-legend");
    this.pickBox = root.querySelector(".pa-pick");
    this.select = root.querySelector(".pa-field");
    this.frames = 0;
    this.pointsObject = null;
    this.fields = [];
    this.buildScene();
    this.buildControls();
    this.render();
  }

  buildScene() {
    const width = this.canvasBox.clientWidth || 640;
    const height = this.canvasBox.clientHeight || 480;
    this.renderer = new WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(1);
    // colours are written as given (no linear-to-sRGB step): a point shows exactly
    // the legend's colour, as in the PNG pictures
    this.renderer.outputColorSpace = LinearSRGBColorSpace;
    this.renderer.setSize(width, height);
    this.renderer.setClearColor(new Color(1, 1, 1), 1);
    this.canvasBox.appendChild(this.renderer.domElement);
    this.scene = new Scene();
    this.scene.add(new AmbientLight(0xffffff, 0.9));
    this.camera = new PerspectiveCamera(35, width / height, 1e-3, 1e3);
    const light = new DirectionalLight(0xffffff, 2.2);
    this.camera.add(light);
    light.position.set(0.5, 1, 2);
    this.scene.add(this.camera);

    const d = this.data;
    this.center = new Vector3(...d.center);
    this.radius = d.radius > 0 ? d.radius : 1;
    if (d.points) this.addPoints(d.points);
    for (const m of d.meshes || []) this.addMesh(m);

    // a view from azimuth 35 deg, elevation 25 deg (the PNG pictures' camera)
    const az = (35 * Math.PI) / 180;
    const elev = (25 * Math.PI) / 180;
    const up = new Vector3(...(d.up || [0, 1, 0]));
    this.camera.up.copy(up);
    const dist = this.radius / Math.sin((this.camera.fov * Math.PI) / 360);
    const dir = this.viewDirection(up, az, elev);
    this.camera.position.copy(this.center).addScaledVector(dir, dist * 1.05);
    this.camera.near = dist / 100;
    this.camera.far = dist * 100;
    this.camera.updateProjectionMatrix();
    this.camera.lookAt(this.center);
  }

  viewDirection(up, az, elev) {
    // an orthonormal frame with `up`; azimuth about up, elevation above the plane
    const helper = Math.abs(up.z) < 0.9 ? new Vector3(0, 0, 1) : new Vector3(1, 0, 0);
    const front = helper.clone().sub(up.clone().multiplyScalar(helper.dot(up))).normalize();
    const side = new Vector3().crossVectors(up, front);
    return front
      .multiplyScalar(Math.cos(elev) * Math.cos(az))
      .addScaledVector(side, Math.cos(elev) * Math.sin(az))
      .addScaledVector(up, Math.sin(elev))
      .normalize();
  }

  addPoints(p) {
    const geometry = new BufferGeometry();
    this.positions = decode(p.positions, Float32Array);
    this.indices = decode(p.indices, Uint32Array);
    geometry.setAttribute("position", new BufferAttribute(this.positions, 3));
    this.fields = p.fields.map((f) => ({
      name: f.name,
      kind: f.kind,
      values: decode(f.values, f.kind === "labels" ? Int32Array : Float32Array),
      legend: f.legend,
      colormap: f.colormap,
      colors: null,
    }));
    this.colorAttr = new BufferAttribute(new Uint8Array(this.positions.length), 3, true);
    geometry.setAttribute("color", this.colorAttr);
    geometry.boundingSphere = new Sphere(this.center.clone(), this.radius);
    const material = new PointsMaterial({
      size: p.point_size,
      sizeAttenuation: false,
      vertexColors: true,
    });
    this.pointsObject = new Points(geometry, material);
    this.scene.add(this.pointsObject);
    this.raycaster = new Raycaster();
  }

  addMesh(m) {
    const vertices = decode(m.vertices, Float32Array);
    const triangles = decode(m.triangles, Uint32Array);
    const geometry = new BufferGeometry();
    let material;
    if (m.face_colors) {
      // per-face colours: one corner per triangle vertex (non-indexed)
      const faceColors = decode(m.face_colors, Uint8Array);
      const pos = new Float32Array(triangles.length * 3);
      const col = new Uint8Array(triangles.length * 3);
      for (let c = 0; c < triangles.length; c++) {
        const v = triangles[c];
        const f = Math.floor(c / 3);
        for (let a = 0; a < 3; a++) {
          pos[3 * c + a] = vertices[3 * v + a];
          col[3 * c + a] = faceColors[3 * f + a];
        }
      }
      geometry.setAttribute("position", new BufferAttribute(pos, 3));
      geometry.setAttribute("color", new BufferAttribute(col, 3, true));
      material = new MeshLambertMaterial({ vertexColors: true, side: DoubleSide, flatShading: true });
    } else {
      geometry.setAttribute("position", new BufferAttribute(vertices, 3));
      geometry.setIndex(new BufferAttribute(triangles, 1));
      material = new MeshLambertMaterial({
        color: new Color(m.color[0] / 255, m.color[1] / 255, m.color[2] / 255),
        side: DoubleSide,
        flatShading: true,
      });
    }
    material.polygonOffset = true;
    material.polygonOffsetFactor = 1;
    material.polygonOffsetUnits = 1;
    if (m.opacity < 1) {
      material.transparent = true;
      material.opacity = m.opacity;
    }
    geometry.computeVertexNormals();
    const mesh = new Mesh(geometry, material);
    this.scene.add(mesh);
    const box = this.root.querySelector(`input.pa-layer[data-layer="${m.id}"]`);
    if (box) {
      box.addEventListener("change", () => {
        mesh.visible = box.checked;
        this.render();
      });
    }
  }

  buildControls() {
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.target.copy(this.center);
    this.controls.update();
    this.controls.addEventListener("change", () => this.render());
    if (this.pointsObject) {
      const box = this.root.querySelector('input.pa-layer[data-layer="points"]');
      if (box) {
        box.addEventListener("change", () => {
          this.pointsObject.visible = box.checked;
          this.render();
        });
      }
      if (this.select) {
        this.select.addEventListener("change", () => this.showField(this.select.value));
      }
      this.showField(this.data.points.initial_field);
      let down = null;
      const canvas = this.renderer.domElement;
      canvas.addEventListener("pointerdown", (e) => {
        down = [e.clientX, e.clientY];
      });
      canvas.addEventListener("pointerup", (e) => {
        // a click, not the end of a rotation
        if (down && Math.hypot(e.clientX - down[0], e.clientY - down[1]) < 4) {
          this.pickAt(e.clientX, e.clientY);
        }
        down = null;
      });
    }
  }

  field(name) {
    return this.fields.find((f) => f.name === name) || this.fields[0];
  }

  showField(name) {
    const f = this.field(name);
    if (!f) return;
    this.current = f;
    if (!f.colors) f.colors = colorsOf(f);
    this.colorAttr.array.set(f.colors);
    this.colorAttr.needsUpdate = true;
    if (this.select && this.select.value !== f.name) this.select.value = f.name;
    this.drawLegend(f);
    this.render();
  }

  drawLegend(f) {
    if (!this.legend) return;
    this.legend.replaceChildren();
    this.legend.appendChild(el("div", { class: "pa-legend-title" }, f.name));
    const lg = f.legend;
    if (f.kind === "labels") {
      const list = el("ul", { class: "pa-swatches" });
      for (const entry of lg.entries) {
        const li = el("li");
        const sw = el("span", { class: "pa-swatch" });
        sw.style.background = `rgb(${entry.color.join(",")})`;
        li.appendChild(sw);
        li.appendChild(document.createTextNode(` ${entry.label} (${entry.count})`));
        list.appendChild(li);
      }
      this.legend.appendChild(list);
      if (lg.n_more > 0) {
        this.legend.appendChild(el("div", {}, `... and ${lg.n_more} more labels`));
      }
    } else {
      const bar = el("div", { class: "pa-colorbar" });
      const stops = lg.stops.map((c, i) => `rgb(${c.join(",")}) ${(100 * i) / (lg.stops.length - 1)}%`);
      bar.style.background = `linear-gradient(to right, ${stops.join(", ")})`;
      this.legend.appendChild(bar);
      const ends = el("div", { class: "pa-colorbar-ends" });
      ends.appendChild(el("span", {}, formatValue(lg.vmin, "scalar")));
      ends.appendChild(el("span", {}, formatValue(lg.vmax, "scalar")));
      this.legend.appendChild(ends);
      if (lg.n_nan > 0) this.legend.appendChild(el("div", {}, `${lg.n_nan} NaN (grey)`));
    }
  }

  // Screen position (client pixels) of shown point k and its depth z in [-1, 1]
  // (smaller is nearer); used by tests and tooling.
  screenPosition(k) {
    const v = new Vector3(
      this.positions[3 * k],
      this.positions[3 * k + 1],
      this.positions[3 * k + 2],
    ).project(this.camera);
    const rect = this.renderer.domElement.getBoundingClientRect();
    return {
      x: rect.left + ((v.x + 1) / 2) * rect.width,
      y: rect.top + ((1 - v.y) / 2) * rect.height,
      z: v.z,
      visible: Math.abs(v.x) < 1 && Math.abs(v.y) < 1 && Math.abs(v.z) < 1,
    };
  }

  pickAt(clientX, clientY) {
    const canvas = this.renderer.domElement;
    const rect = canvas.getBoundingClientRect();
    const ndc = new Vector2(
      ((clientX - rect.left) / rect.width) * 2 - 1,
      -((clientY - rect.top) / rect.height) * 2 + 1,
    );
    // the pick radius in world units at the orbit target's depth
    const depth = this.camera.position.distanceTo(this.controls.target);
    const worldPerPx =
      (2 * depth * Math.tan((this.camera.fov * Math.PI) / 360)) / rect.height;
    this.raycaster.params.Points.threshold = PICK_RADIUS_PX * worldPerPx;
    this.raycaster.setFromCamera(ndc, this.camera);
    const hits = this.raycaster.intersectObject(this.pointsObject, false);
    if (!hits.length) {
      this.showPick(null);
      return null;
    }
    // the front-most point within the radius
    this.showPick(hits[0].index);
    return hits[0].index;
  }

  showPick(k) {
    if (!this.pickBox) return;
    this.pickBox.replaceChildren();
    if (k === null) {
      this.pickBox.appendChild(el("span", {}, "no point under the cursor"));
      this.root.dataset.picked = "";
      return;
    }
    const index = this.indices[k];
    this.root.dataset.picked = String(index);
    const table = el("table", { class: "pa-pick-table" });
    const row = (name, value) => {
      const tr = el("tr");
      tr.appendChild(el("th", {}, name));
      tr.appendChild(el("td", { "data-field": name }, value));
      table.appendChild(tr);
    };
    row("index", String(index));
    // positions are stored relative to data.offset (float32 keeps its precision)
    const off = this.data.offset || [0, 0, 0];
    const xyz = [0, 1, 2].map((a) => formatValue(off[a] + this.positions[3 * k + a], "scalar"));
    row("x, y, z", xyz.join(", "));
    for (const f of this.fields) row(f.name, formatValue(f.values[k], f.kind));
    this.pickBox.appendChild(table);
  }

  render() {
    this.renderer.render(this.scene, this.camera);
    this.frames += 1;
  }
}

function mountAll() {
  const views = [];
  window.pointatlasViews = views;
  for (const root of document.querySelectorAll(".pa-view")) {
    const script = root.querySelector("script.pa-data");
    try {
      const view = new View(root, JSON.parse(script.textContent));
      views.push(view);
      root.dataset.ready = "1";
    } catch (err) {
      root.dataset.ready = "error";
      const box = root.querySelector(".pa-canvas");
      if (box) box.textContent = `3-D view not available: ${err.message}`;
      console.error(err);
    }
  }
  window.pointatlasReady = true;
}

if (document.readyState === "loading") {
  document.addEventListener("DOMContentLoaded", mountAll);
} else {
  mountAll();
}
