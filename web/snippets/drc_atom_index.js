// Reading a raw tracemesh Draco file (`GET /jobs/{id}/mesh?format=draco`, .drc) with three.js' DRACOLoader and its
// custom attributes. DRACOLoader's default map only knows position, normal, color and uv; given an attribute map it
// looks every attribute up by its Draco unique id instead. tracemesh writes position as id 0, normal 1,
// atom_index 2 (0-based index of the atom contributing most to φ at the vertex) and component 3 (index into the
// report's `components`), both int32.
// tests/node/web_viewer_test.mjs runs this file as is.
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';

const tracemeshAttributeIds = { position: 0, normal: 1, atom_index: 2, component: 3 };
// Typed-array names (the map travels to DRACOLoader's worker as JSON).
const tracemeshAttributeTypes = {
  position: 'Float32Array',
  normal: 'Float32Array',
  atom_index: 'Uint32Array',
  component: 'Int32Array',
};

/// Decodes the .drc at `url`; resolves to a BufferGeometry with attributes position, normal, atom_index, component.
/// `dracoDecoderPath`: a URL ending in '/' holding draco_wasm_wrapper.js and draco_decoder.wasm.
export async function decodeTracemeshDrc(url, dracoDecoderPath) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  const bytes = await response.arrayBuffer();
  const loader = new DRACOLoader().setDecoderPath(dracoDecoderPath);
  try {
    return await new Promise((resolve, reject) => {
      loader.decodeDracoFile(bytes, resolve, tracemeshAttributeIds, tracemeshAttributeTypes, undefined, reject);
    });
  } finally {
    loader.dispose();
  }
}
