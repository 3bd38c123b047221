// Reading a tracemesh GLB (`GET /jobs/{id}/mesh?format=glb`: Draco-compressed, KHR_draco_mesh_compression) with
// three.js, and the atom behind each vertex. GLTFLoader keeps a custom glTF attribute under its lower-cased name:
// _ATOM_INDEX becomes the geometry attribute `_atom_index` (0-based index of the atom contributing most to φ at
// the vertex, in the order of the uploaded file's atoms) and _COMPONENT becomes `_component` (index into the
// report's `components`). Both arrive as Float32Array (exact for integers below 2^24).
// The web viewer loads its meshes with these two functions; tests/node/web_viewer_test.mjs runs this file as is.
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

/// A GLTFLoader that decodes Draco with the decoder found at `dracoDecoderPath` (a URL ending in '/', holding
/// draco_wasm_wrapper.js and draco_decoder.wasm; tracemeshd serves them, see the page's source).
export function createTracemeshGltfLoader(dracoDecoderPath) {
  const draco = new DRACOLoader().setDecoderPath(dracoDecoderPath);
  return new GLTFLoader().setDRACOLoader(draco);
}

/// Loads the GLB at `url`; resolves to { mesh, geometry, atomIndex, component }.
export async function loadTracemeshGlb(loader, url) {
  return readTracemeshGltf(await loader.loadAsync(url), url);
}

/// The mesh of a loaded tracemesh glTF (what GLTFLoader's load/parse gives) and its per-vertex attributes.
export function readTracemeshGltf(gltf, what = 'the glTF') {
  let mesh = null;
  gltf.scene.traverse((object) => {
    if (object.isMesh && !mesh) mesh = object;
  });
  if (!mesh) throw new Error(`${what} holds no mesh`);
  const geometry = mesh.geometry;
  return {
    mesh,
    geometry,
    atomIndex: geometry.getAttribute('_atom_index')?.array ?? null,
    component: geometry.getAttribute('_component')?.array ?? null,
  };
}
