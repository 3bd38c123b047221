// The atoms of the uploaded file, in the order tracemeshd reads them, for colouring by the vertex attribute
// _ATOM_INDEX (the index of the atom contributing most to φ at each vertex). The format is recognised from the
// content as the server does (docs/formats.md). PQR is read record by record exactly as the server counts
// atoms (every ATOM/HETATM record, zero radii included), so indices match; xyzr has neither charges nor residues.
// PDB and mmCIF are not read here: the server drops waters, keeps one alternate location and the first model by
// default, so matching its atom order would mean re-implementing gemmi's reading; the page colours those by
// component only.

/// Bytes → text, undoing gzip (magic 1f 8b) as the server does.
export async function fileText(file) {
  const head = new Uint8Array(await file.slice(0, 2).arrayBuffer());
  if (head[0] === 0x1f && head[1] === 0x8b) {
    const stream = file.stream().pipeThrough(new DecompressionStream('gzip'));
    return new Response(stream).text();
  }
  return file.text();
}

const isNumber = (text) => text !== '' && Number.isFinite(Number(text));

/// 'mmcif', 'xyzr', 'pdb' or 'pqr', by the server's rules (core/io/input_format.cpp): mmCIF from a leading data_
/// block, xyzr from a first line of four numbers, PDB after a HEADER or CRYST1 line before any atom; otherwise the
/// majority of the ATOM/HETATM records decides (PQR when at least half end with five numbers), so one damaged line
/// does not turn a PQR file into PDB.
export function detectFormat(text) {
  let start = 0;
  let first = true;
  let pqrRecords = 0;
  let otherRecords = 0;
  while (start < text.length) {
    let end = text.indexOf('\n', start);
    if (end < 0) end = text.length;
    const line = text.slice(start, end).replace(/\r$/, '');
    start = end + 1;
    if (line.trim() === '') continue;
    if (first) {
      first = false;
      if (line.startsWith('data_')) return 'mmcif';
      const fields = line.trim().split(/\s+/);
      if (fields.length === 4 && fields.every(isNumber)) return 'xyzr';
    }
    if (pqrRecords + otherRecords === 0 && (line.startsWith('HEADER') || line.startsWith('CRYST1'))) return 'pdb';
    if (line.startsWith('ATOM') || line.startsWith('HETATM')) {
      const fields = line.trim().split(/\s+/);
      if (fields.length >= 6 && fields.slice(-5).every(isNumber)) ++pqrRecords;
      else ++otherRecords;
    }
  }
  return pqrRecords >= otherRecords ? 'pqr' : 'pdb';
}

/// PQR: ATOM/HETATM records of 10 fields (ATOM serial name resName resSeq x y z charge radius) or 11 (a chain id
/// before resSeq). With 10 fields a chain id may be glued to resSeq ("A1000"). A capsid has ~10⁵–10⁶ records: the
/// text is scanned line by line without splitting it whole, and the page gets the main thread back every
/// `recordsPerSlice` records so that it stays responsive.
async function readPqr(text) {
  const recordsPerSlice = 20000;
  const charge = [];
  const chain = [];
  const residueName = [];
  const whitespace = /\s+/;
  const gluedChain = /^([A-Za-z]+)-?\d+[A-Za-z]?$/;
  let start = 0;
  while (start < text.length) {
    let end = text.indexOf('\n', start);
    if (end < 0) end = text.length;
    if (text.startsWith('ATOM', start) || text.startsWith('HETATM', start)) {
      const fields = text.slice(start, end).trim().split(whitespace);
      const chainId = fields.length === 11 ? fields[4] : (gluedChain.exec(fields[4] ?? '')?.[1] ?? '');
      charge.push(Number(fields[fields.length - 2]));
      chain.push(chainId);
      residueName.push(fields[3]);
      if (charge.length % recordsPerSlice === 0) await new Promise((resolve) => setTimeout(resolve));
    }
    start = end + 1;
  }
  return { format: 'pqr', count: charge.length, charge, chain, residueName };
}

function readXyzr(text) {
  const count = text.split(/\r?\n/).filter((line) => line.trim() !== '').length;
  return { format: 'xyzr', count, charge: null, chain: null, residueName: null };
}

/// The per-atom properties the page can colour by ({format, count, charge, chain, residueName}; a
/// property the format lacks is null).
export async function readAtoms(file) {
  const text = await fileText(file);
  const format = detectFormat(text);
  if (format === 'pqr') return readPqr(text);
  if (format === 'xyzr') return readXyzr(text);
  return { format, count: null, charge: null, chain: null, residueName: null };
}
