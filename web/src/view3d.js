// The 3D view: each object's input ("before") and output ("after") meshes, orbit/pan/zoom
// (OrbitControls), before/after/split display, a section plane and per-vertex overlays. The
// world's up axis is the scene's (y for glTF, z otherwise); an object with a texture is drawn on
// its mesh split along its UV seams (`display`), positions, smooth normals and overlay colours
// gathered from the object's vertices.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

const BASE_COLORS = [0xd9a66b, 0x7fa7c9, 0x9ccf8a, 0xc98fc0, 0xcfc46e];
// Faces that intersect another face (the overlay of intersecting faces).
const RED = [0.92, 0.12, 0.1];

// A colormap from dark blue through teal and yellow (t in [0, 1]).
function ramp(t) {
  const c = Math.min(1, Math.max(0, t));
  return [0.15 + 0.85 * c * c, 0.2 + 0.7 * Math.sin(c * Math.PI * 0.9), 0.55 * (1 - c) + 0.1];
}

export class View3D {
  constructor(container) {
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(1);
    this.renderer.localClippingEnabled = true;
    container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x30343a);
    this.camera = new THREE.PerspectiveCamera(35, 1, 0.01, 1000);
    this.camera.up.set(0, 0, 1);
    this.up = 'z';
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener('change', () => this.render());
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x404050, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 1.8);
    sun.position.set(3, -4, 6);
    this.camera.add(sun);
    this.scene.add(this.camera);
    this.before = new THREE.Group();
    this.after = new THREE.Group();
    this.scene.add(this.before, this.after);
    this.section = new THREE.Plane(new THREE.Vector3(-1, 0, 0), 0);
    this.sectionOn = false;
    this.show = 'after';
    this.overlay = 'none';
    this.objects = [];
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  // Builds the meshes of the scene's objects (triangles fixed; positions per frame).
  build(sceneView) {
    this.up = sceneView.up === 'y' ? 'y' : 'z';
    if (this.up === 'y') this.camera.up.set(0, 1, 0);
    else this.camera.up.set(0, 0, 1);
    this.textures = new THREE.TextureLoader();
    this.objects = sceneView.objects.map((object, i) => {
      const display = object.display ?? null;
      let texture = null;
      if (display && object.texture) {
        // glTF's texture coordinates point down the image (three.js' GLTFLoader: flipY off).
        texture = this.textures.load(object.texture, () => this.render());
        texture.flipY = false;
        texture.colorSpace = THREE.SRGBColorSpace;
      }
      const make = (group, opacity) => {
        const geometry = new THREE.BufferGeometry();
        geometry.setIndex(display ? display.triangles : object.triangles);
        if (display) geometry.setAttribute('uv', new THREE.Float32BufferAttribute(display.uv, 2));
        const material = new THREE.MeshStandardMaterial({
          color: 0xffffff, vertexColors: true, roughness: 0.65, metalness: 0.0, map: texture,
          side: THREE.DoubleSide, transparent: opacity < 1, opacity, clippingPlanes: [],
        });
        const mesh = new THREE.Mesh(geometry, material);
        mesh.userData.object = i;
        group.add(mesh);
        return mesh;
      };
      return {
        name: object.name, before: make(this.before, 1), after: make(this.after, 1), frame: null,
        triangles: object.triangles, display, texture,
      };
    });
  }

  // Per drawn vertex, `values` (per object vertex, `width` numbers each) of its object vertex.
  gather(entry, values, width) {
    if (!entry.display) return values;
    const vertex = entry.display.vertex;
    const out = new Float32Array(vertex.length * width);
    for (let d = 0; d < vertex.length; d++) {
      for (let c = 0; c < width; c++) out[d * width + c] = values[vertex[d] * width + c];
    }
    return out;
  }

  // Smooth vertex normals of the object's own mesh (across UV seams), area weighted.
  static normals(positions, triangles) {
    const normals = new Float32Array(positions.length);
    for (let t = 0; t < triangles.length; t += 3) {
      const [a, b, c] = [triangles[t] * 3, triangles[t + 1] * 3, triangles[t + 2] * 3];
      const ux = positions[b] - positions[a], uy = positions[b + 1] - positions[a + 1], uz = positions[b + 2] - positions[a + 2];
      const vx = positions[c] - positions[a], vy = positions[c + 1] - positions[a + 1], vz = positions[c + 2] - positions[a + 2];
      const n = [uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx];
      for (const v of [a, b, c]) for (let k = 0; k < 3; k++) normals[v + k] += n[k];
    }
    for (let v = 0; v < normals.length; v += 3) {
      const l = Math.hypot(normals[v], normals[v + 1], normals[v + 2]) || 1;
      for (let k = 0; k < 3; k++) normals[v + k] /= l;
    }
    return normals;
  }

  // Positions and overlays of a computed frame.
  update(frame) {
    frame.objects.forEach((object, i) => {
      const entry = this.objects[i];
      if (!entry) return;
      entry.frame = object;
      for (const [mesh, source] of [[entry.before, object.input], [entry.after, object.output]]) {
        const positions = this.gather(entry, source, 3);
        const attribute = mesh.geometry.getAttribute('position');
        if (attribute && attribute.count * 3 === positions.length) {
          attribute.array.set(positions);
          attribute.needsUpdate = true;
        } else {
          mesh.geometry.setAttribute('position', new THREE.Float32BufferAttribute(positions, 3));
        }
        if (entry.display) {
          const normals = this.gather(entry, View3D.normals(source, entry.triangles), 3);
          mesh.geometry.setAttribute('normal', new THREE.Float32BufferAttribute(normals, 3));
        } else {
          mesh.geometry.computeVertexNormals();
        }
        mesh.geometry.computeBoundingSphere();
        mesh.geometry.computeBoundingBox();
      }
      this.colour(i);
    });
    this.render();
  }

  colour(i) {
    const entry = this.objects[i];
    const object = entry.frame;
    const n = object.output.length / 3;
    // A textured object shows its texture (white multiplies it unchanged) under the overlays.
    const base = new THREE.Color(entry.texture ? 0xffffff : BASE_COLORS[i % BASE_COLORS.length]);
    const colours = new Float32Array(n * 3);
    const o = object.overlays;
    const painted = object.painted;
    let etaMax = 1;
    if (o) for (const eta of o.bulge_map) etaMax = Math.max(etaMax, eta);
    // Faces that intersect another face: each side shows its own (input before, output after).
    const overlaps = this.overlay === 'intersecting' ? object.intersecting : null;
    const before = overlaps ? new Float32Array(n * 3) : colours;
    for (let v = 0; v < n; v++) {
      let c = [base.r, base.g, base.b];
      if (overlaps) {
        before.set(overlaps.input[v] ? RED : c, v * 3);
        if (overlaps.output[v]) c = RED;
      }
      if (this.overlay === 'contact' && o && o.contact[v]) c = [0.9, 0.15, 0.12];
      else if (this.overlay === 'deformable' && o && o.deformable[v]) c = [0.25, 0.45, 0.95];
      else if (this.overlay === 'u' && o && o.u[v] >= 0) c = ramp(o.u[v]);
      else if (this.overlay === 'bulge') {
        const eta = o ? o.bulge_map[v] : painted ? painted[v] : 1;
        c = ramp(eta / Math.max(etaMax, 2));
      }
      colours.set(c, v * 3);
    }
    entry.before.geometry.setAttribute('color', new THREE.Float32BufferAttribute(this.gather(entry, before, 3), 3));
    entry.after.geometry.setAttribute('color', new THREE.Float32BufferAttribute(this.gather(entry, colours, 3), 3));
  }

  setOverlay(overlay) {
    this.overlay = overlay;
    this.objects.forEach((_, i) => this.objects[i].frame && this.colour(i));
    this.render();
  }

  setShow(show) {
    this.show = show;
    this.render();
  }

  // The section plane at a fraction of the scene's x extent (keeps x below it).
  setSection(on, fraction) {
    this.sectionOn = on;
    const box = this.bounds();
    if (!box.isEmpty()) this.section.constant = box.min.x + fraction * (box.max.x - box.min.x);
    for (const entry of this.objects) {
      for (const mesh of [entry.before, entry.after]) mesh.material.clippingPlanes = on ? [this.section] : [];
    }
    this.render();
  }

  bounds() {
    const box = new THREE.Box3();
    for (const entry of this.objects) {
      if (entry.after.geometry.boundingBox) box.union(entry.after.geometry.boundingBox);
    }
    return box;
  }

  // Frames the contact zones (every object when nothing touches).
  frameContact() {
    const box = new THREE.Box3();
    const p = new THREE.Vector3();
    for (const entry of this.objects) {
      const o = entry.frame?.overlays;
      if (!o) continue;
      const out = entry.frame.output;
      for (let v = 0; v < o.deformable.length; v++) {
        if (o.deformable[v]) box.expandByPoint(p.set(out[3 * v], out[3 * v + 1], out[3 * v + 2]));
      }
    }
    if (box.isEmpty()) box.copy(this.bounds());
    if (box.isEmpty()) return;
    const centre = box.getCenter(new THREE.Vector3());
    const radius = Math.max(box.getSize(new THREE.Vector3()).length() / 2, 1e-3);
    const distance = radius / Math.sin((this.camera.fov * Math.PI) / 360);
    this.controls.target.copy(centre);
    // From the front, a little to the side and above: glTF characters face +z with y up.
    const eye = this.up === 'y' ? new THREE.Vector3(0.5, 0.35, 1.6) : new THREE.Vector3(0.9, -1.6, 0.8);
    this.camera.position.copy(centre).add(eye.normalize().multiplyScalar(distance));
    this.camera.near = distance / 100;
    this.camera.far = distance * 100;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.render();
  }

  // The point of object `object`'s input mesh under the pointer, if any.
  pick(event, object) {
    const rect = this.renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((event.clientX - rect.left) / rect.width) * 2 - 1, -((event.clientY - rect.top) / rect.height) * 2 + 1);
    const raycaster = new THREE.Raycaster();
    raycaster.setFromCamera(ndc, this.camera);
    const entry = this.objects[object];
    if (!entry) return null;
    const hits = raycaster.intersectObject(entry.before, false);
    return hits.length ? hits[0].point : null;
  }

  resize() {
    const { clientWidth: w, clientHeight: h } = this.container;
    if (!w || !h) return;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.render();
  }

  render() {
    const r = this.renderer;
    const { width, height } = r.domElement;
    if (this.show === 'split') {
      r.setScissorTest(true);
      for (const [x, showBefore] of [[0, true], [width / 2, false]]) {
        this.before.visible = showBefore;
        this.after.visible = !showBefore;
        r.setViewport(x, 0, width / 2, height);
        r.setScissor(x, 0, width / 2, height);
        this.camera.aspect = width / 2 / height;
        this.camera.updateProjectionMatrix();
        r.render(this.scene, this.camera);
      }
      r.setScissorTest(false);
      r.setViewport(0, 0, width, height);
      this.camera.aspect = width / height;
      this.camera.updateProjectionMatrix();
      return;
    }
    this.before.visible = this.show === 'before';
    this.after.visible = this.show === 'after';
    r.render(this.scene, this.camera);
  }
}
