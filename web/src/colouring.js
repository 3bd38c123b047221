// Per-vertex colours of the mesh: by component (cavities distinct), by the nearest atom's chain, residue or charge.
import { Color } from 'three';

const outerColour = new Color(0xc8d2e0);
// Distinct, saturated colours for categories; cavities and other components cycle through them.
const palette = [0xe6194b, 0x3cb44b, 0xffa51e, 0x4363d8, 0xf58231, 0x911eb4, 0x42d4f4, 0xf032e6, 0xbfef45,
  0xfabed4, 0x469990, 0xdcbeff, 0x9a6324, 0xfffac8, 0x800000, 0xaaffc3, 0x808000, 0xffd8b1, 0x000075, 0xa9a9a9]
  .map((hex) => new Color(hex));

/// The component that is the molecule's outside: the report's non-cavity component with the most vertices.
export function outerComponent(components) {
  let best = 0;
  components.forEach((component, index) => {
    const current = components[best];
    if (!component.cavity && (current.cavity || component.vertices > current.vertices)) best = index;
  });
  return best;
}

function fill(colours, count, colourOf) {
  for (let v = 0; v < count; ++v) colourOf(v).toArray(colours, 3 * v);
}

/// By component: the outer surface grey-blue, every other component (cavities, separate molecules) its own colour.
function byComponent(colours, count, component, components) {
  const outer = outerComponent(components);
  fill(colours, count, (v) => (component[v] === outer ? outerColour : palette[component[v] % palette.length]));
}

/// One palette colour per distinct value of `key` (chain id or residue name), in order of first appearance.
function byCategory(colours, count, atomIndex, key) {
  const categories = new Map();
  const atomColour = key.map((value) => {
    if (!categories.has(value)) categories.set(value, palette[categories.size % palette.length]);
    return categories.get(value);
  });
  fill(colours, count, (v) => atomColour[atomIndex[v]] ?? outerColour);
  return categories.size;
}

/// Charge on a blue-white-red scale, saturating at the 95th percentile of |charge| (most partial charges are
/// small, a few ions are ±1 or more).
function byCharge(colours, count, atomIndex, charge) {
  const magnitudes = charge.map(Math.abs).sort((a, b) => a - b);
  const scale = magnitudes[Math.floor(0.95 * (magnitudes.length - 1))] || 1;
  const white = new Color(1, 1, 1);
  const red = new Color(0xd7301f);
  const blue = new Color(0x2166ac);
  const scratch = new Color();
  fill(colours, count, (v) => {
    const q = charge[atomIndex[v]] ?? 0;
    const t = Math.min(1, Math.abs(q) / scale);
    return scratch.copy(white).lerp(q < 0 ? red : blue, t);
  });
  return scale;
}

/// Which colour modes the loaded mesh and atoms support: mode → reason it is unavailable, or null.
export function unavailableModes(atoms, atomIndex) {
  const reasons = {
    pqr: null,
    xyzr: 'an xyzr file has no chains, residues or charges',
    pdb: 'PDB files are coloured by component only in this viewer',
    mmcif: 'mmCIF files are coloured by component only in this viewer',
  };
  const pqrOnly = atoms.format in reasons ? reasons[atoms.format] : 'the page could not read the atoms of this file';
  const noIndex = !atomIndex ? 'the mesh has no atom indices' : null;
  return {
    component: null,
    chain: noIndex ?? pqrOnly ?? (atoms.chain.every((c) => c === '') ? 'the PQR file has no chain ids' : null),
    residue: noIndex ?? pqrOnly,
    charge: noIndex ?? pqrOnly,
  };
}

/// Fills `colours` (Float32Array, 3 per vertex) for `mode`; returns a one-line legend.
export function colourVertices(colours, mode, { component, atomIndex, components, atoms }) {
  const count = colours.length / 3;
  switch (mode) {
    case 'chain':
      return `${byCategory(colours, count, atomIndex, atoms.chain)} chains`;
    case 'residue':
      return `${byCategory(colours, count, atomIndex, atoms.residueName)} residue types`;
    case 'charge':
      return `red negative, blue positive; full colour at |q| ≥ ${byCharge(colours, count, atomIndex, atoms.charge).toFixed(2)} e`;
    default: {
      byComponent(colours, count, component, components);
      const cavities = components.filter((c) => c.cavity).length;
      return `${components.length} components, ${cavities} cavities (coloured; the outer surface grey)`;
    }
  }
}
