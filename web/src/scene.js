// The three.js view: one mesh, orbit and zoom with OrbitControls, fit to view, rendering only when something
// changed (a large mesh on a software renderer must not keep a core busy).
import {
  AmbientLight, BufferAttribute, Color, DirectionalLight, FrontSide, Mesh, MeshStandardMaterial, PerspectiveCamera,
  Scene, Sphere, WebGLRenderer,
} from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

export class MeshView {
  constructor(canvas) {
    this.renderer = new WebGLRenderer({ canvas, antialias: true });
    this.renderer.setPixelRatio(window.devicePixelRatio);
    this.scene = new Scene();
    this.scene.background = new Color(0xf4f5f7);
    this.camera = new PerspectiveCamera(40, 1, 0.1, 1000);
    this.scene.add(new AmbientLight(0xffffff, 0.6));
    this.light = new DirectionalLight(0xffffff, 2.2);
    this.camera.add(this.light);  // a headlight: the lit side is always the visible one
    this.light.position.set(0.3, 0.6, 1);
    this.scene.add(this.camera);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.addEventListener('change', () => this.requestRender());
    this.outerMaterial = new MeshStandardMaterial({ vertexColors: true, roughness: 0.55, side: FrontSide });
    this.innerMaterial = new MeshStandardMaterial({ vertexColors: true, roughness: 0.55, side: FrontSide });
    this.mesh = null;
    this.renderPending = false;
    this.onFirstFrame = null;
    new ResizeObserver(() => this.resize()).observe(canvas);
  }

  resize() {
    const canvas = this.renderer.domElement;
    const width = canvas.clientWidth;
    const height = canvas.clientHeight;
    if (width === 0 || height === 0) return;
    this.renderer.setSize(width, height, false);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  requestRender() {
    if (this.renderPending) return;
    this.renderPending = true;
    requestAnimationFrame(() => {
      this.renderPending = false;
      this.renderer.render(this.scene, this.camera);
      if (this.mesh && this.onFirstFrame) {
        const callback = this.onFirstFrame;
        this.onFirstFrame = null;
        callback();
      }
    });
  }

  /// Shows `geometry` (from GLTFLoader) with a colour attribute; triangles of the `outer` component first, so the
  /// outer surface can be made see-through to show cavities (two draw groups, two materials).
  show(geometry, component, outer) {
    if (this.mesh) {
      this.scene.remove(this.mesh);
      this.mesh.geometry.dispose();
    }
    groupTrianglesByOuter(geometry, component, outer);
    geometry.setAttribute('color', new BufferAttribute(new Float32Array(3 * geometry.getAttribute('position').count), 3));
    this.mesh = new Mesh(geometry, [this.outerMaterial, this.innerMaterial]);
    this.scene.add(this.mesh);
    this.fit();
  }

  coloursChanged() {
    this.mesh.geometry.getAttribute('color').needsUpdate = true;
    this.requestRender();
  }

  setOuterOpacity(opacity) {
    this.outerMaterial.transparent = opacity < 1;
    this.outerMaterial.opacity = opacity;
    this.outerMaterial.depthWrite = opacity >= 1;
    this.outerMaterial.needsUpdate = true;
    this.requestRender();
  }

  /// Camera on the mesh's bounding sphere, looking down −z, the whole sphere in view.
  fit() {
    if (!this.mesh) return;
    const geometry = this.mesh.geometry;
    geometry.computeBoundingSphere();
    const sphere = geometry.boundingSphere ?? new Sphere();
    const halfFov = (this.camera.fov * Math.PI) / 360;
    const distance = (sphere.radius / Math.sin(Math.min(halfFov, halfFov * this.camera.aspect))) * 1.05;
    this.camera.position.copy(sphere.center).add({ x: 0, y: 0, z: distance });
    // Fixed for the mesh, not the camera position, so zooming in and out keeps it in range.
    this.camera.near = sphere.radius / 100;
    this.camera.far = distance * 20;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(sphere.center);
    this.controls.update();
    this.requestRender();
  }
}

/// Reorders the triangles so that those of component `outer` (by their first vertex) come first; group 0 draws
/// them with the outer material, group 1 the rest.
function groupTrianglesByOuter(geometry, component, outer) {
  const index = geometry.getIndex().array;
  const triangles = index.length / 3;
  const sorted = new Uint32Array(index.length);
  let front = 0;
  let back = index.length;
  for (let t = 0; t < triangles; ++t) {
    let at;
    if (component[index[3 * t]] === outer) {
      at = front;
      front += 3;
    } else {
      back -= 3;
      at = back;
    }
    sorted[at] = index[3 * t];
    sorted[at + 1] = index[3 * t + 1];
    sorted[at + 2] = index[3 * t + 2];
  }
  geometry.setIndex(new BufferAttribute(sorted, 1));
  geometry.clearGroups();
  geometry.addGroup(0, front, 0);
  geometry.addGroup(front, index.length - front, 1);
}
