// The tracemesh web viewer: upload a molecule, follow its job, show the certified mesh and its report.
import { createTracemeshGltfLoader, readTracemeshGltf } from '../snippets/glb_atom_index.js';
import { colourVertices, outerComponent, unavailableModes } from './colouring.js';
import { cancelJob, followJob, submitJob } from './job_client.js';
import { readAtoms } from './molecule_atoms.js';
import { MeshView } from './scene.js';

// DRACOLoader's decoder (draco_wasm_wrapper.js, draco_decoder.wasm) is served next to this bundle.
const dracoDecoderPath = new URL('./', import.meta.url).href;
const downloadFormats = [
  { format: 'off', suffix: '.off' },
  { format: 'draco', suffix: '.drc' },
  { format: 'glb', suffix: '.glb' },
  { format: 'glb-raw', suffix: '-raw.glb' },
  { format: 'ply', suffix: '.ply' },
];

const $ = (id) => document.getElementById(id);
const view = new MeshView($('canvas'));
const gltfLoader = createTracemeshGltfLoader(dracoDecoderPath);

/// What the page is doing, for people reading the DOM (and the browser test): times are performance.now() ms.
const viewer = { jobId: null, job: null, times: {} };
window.tracemeshViewer = viewer;

let chosenFile = null;
let atomsPending = null;  // Promise of readAtoms(chosenFile)
let owner = null;         // { id, token } of the running submission
let shown = null;         // { geometry, colours, atomIndex, component, components, atoms }

function setMessage(text) {
  $('message').textContent = text;
}

function setPictureState(state) {
  $('picture-status').dataset.state = state;
}

function chooseFile(file) {
  if (!file) return;
  chosenFile = file;
  // The server decides whether the file is valid; the page only loses its atom colours when it cannot read it.
  atomsPending = readAtoms(file).catch(() => ({ format: 'unreadable', count: null, charge: null, chain: null,
    residueName: null }));
  $('file-name').textContent = `${file.name} (${(file.size / 1024).toFixed(1)} KiB)`;
  $('submit').disabled = false;
  setMessage('');
}

// ---- progress -------------------------------------------------------------------------------------------------

function formatEta(seconds) {
  if (typeof seconds !== 'number' || !Number.isFinite(seconds)) return '—';
  if (seconds < 60) return `${Math.ceil(seconds)} s`;
  return `${Math.floor(seconds / 60)} min ${Math.ceil(seconds % 60)} s`;
}

function showProgress(job) {
  viewer.job = job;
  $('progress').hidden = false;
  $('progress-bar').value = job.status === 'done' ? 1 : job.progress ?? 0;
  const waiting = job.status === 'queued' && job.queue_position != null ? ` (position ${job.queue_position})` : '';
  $('status-text').textContent = job.status + waiting;
  $('stage-text').textContent = job.status === 'running' ? job.stage ?? '—' : '—';
  $('eta-text').textContent = job.status === 'done' ? '—' : formatEta(job.eta_s);
}

// ---- report ---------------------------------------------------------------------------------------------------

const integer = (value) => value.toLocaleString('en-US');
const decimals = (digits) => (value) =>
  value.toLocaleString('en-US', { minimumFractionDigits: digits, maximumFractionDigits: digits });

/// The report rows: label, path in the report JSON (data-field; an array shows its length), formatter.
const reportRows = [
  ['certified', 'certificate.certified', (value) => (value ? 'yes' : 'NO')],
  ['vertices', 'vertices', integer],
  ['triangles', 'triangles', integer],
  ['area (Å²)', 'area', decimals(1)],
  ['volume (Å³)', 'volume', decimals(1)],
  ['components', 'components', integer],
  ['cavities', 'cavities', integer],
  ['genus', 'genus', integer],
  ['method', 'method', String],
  ['refine', 'refine', String],
  ['achieved density (v/Å²)', 'achieved_density', decimals(3)],
];

function valueAt(report, path) {
  const value = path.split('.').reduce((node, key) => node?.[key], report);
  return Array.isArray(value) ? value.length : value;
}

function definitionList(element, rows) {
  element.replaceChildren(...rows.flatMap(([label, field, text]) => {
    const term = document.createElement('dt');
    term.textContent = label;
    const definition = document.createElement('dd');
    definition.dataset.field = field;
    definition.textContent = text;
    return [term, definition];
  }));
}

function showReport(id, report) {
  definitionList($('report-fields'), reportRows.map(([label, path, format]) => {
    const value = valueAt(report, path);
    return [label, path, value == null ? '—' : format(value)];
  }));
  definitionList($('report-timings'), Object.entries(report.timings ?? {}).map(([stage, seconds]) =>
    [stage, `timings.${stage}`, decimals(3)(seconds)]));
  const base = (chosenFile?.name ?? id).replace(/\.gz$/, '').replace(/\.[^.]*$/, '') || id.slice(0, 12);
  $('downloads').replaceChildren(...downloadFormats.map(({ format, suffix }) => {
    const link = document.createElement('a');
    link.href = `/jobs/${id}/mesh?format=${format}`;
    link.download = base + suffix;
    link.textContent = format;
    link.dataset.format = format;
    return link;
  }));
  $('report').hidden = false;
}

// ---- the mesh -------------------------------------------------------------------------------------------------

function applyColours() {
  const mode = $('colour-mode').value;
  const legend = colourVertices(shown.colours, mode, shown);
  $('colour-note').textContent = shown.atomNote ? `${legend}. ${shown.atomNote}.` : legend;
  view.coloursChanged();
}

async function showMesh(id, report, atomsPromise) {
  setPictureState('loading');
  // Fetched here rather than by the loader so that download (the server encodes a format on its first request)
  // and decoding are timed apart.
  const url = `/jobs/${id}/mesh?format=glb`;
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  const bytes = await response.arrayBuffer();
  viewer.times.meshDownloaded = performance.now();
  const { geometry, atomIndex, component } = readTracemeshGltf(await gltfLoader.parseAsync(bytes, ''), url);
  viewer.times.meshDecoded = performance.now();
  const atoms = await atomsPromise;
  viewer.atomCount = atoms.count;
  const components = report.components;
  view.show(geometry, component, outerComponent(components));
  const unavailable = unavailableModes(atoms, atomIndex);
  shown = { geometry, colours: geometry.getAttribute('color').array, atomIndex, component, components, atoms,
    atomNote: unavailable.charge };
  for (const option of $('colour-mode').options) {
    option.disabled = unavailable[option.value] !== null;
    option.title = unavailable[option.value] ?? '';
  }
  $('colour-mode').value = 'component';
  $('outer-opacity').value = 1;
  view.setOuterOpacity(1);
  applyColours();
  $('view-options').hidden = false;
  await new Promise((resolve) => {
    view.onFirstFrame = resolve;
    view.requestRender();
  });
  viewer.times.firstFrame = performance.now();
  setPictureState('shown');
}

// ---- the job --------------------------------------------------------------------------------------------------

function formParameters() {
  const form = $('job-form');
  const parameters = {};
  for (const name of ['density', 'd', 't0', 'method', 'refine']) parameters[name] = form.elements[name].value;
  return parameters;
}

async function runJob() {
  $('submit').disabled = true;
  setMessage('');
  setPictureState('working');
  const atomsPromise = atomsPending;  // of the file submitted, whatever is chosen while the job runs
  viewer.times = { submitted: performance.now() };
  try {
    const accepted = await submitJob(chosenFile, formParameters());
    owner = { id: accepted.id, token: accepted.token };
    viewer.jobId = accepted.id;
    $('cancel').disabled = false;
    const job = await followJob(accepted.id, showProgress);
    viewer.times.finished = performance.now();
    $('cancel').disabled = true;
    if (job.status !== 'done') {
      setPictureState(job.status);
      setMessage(job.status === 'cancelled' ? 'The job was cancelled.'
        : `The job failed: ${job.error?.message ?? 'no reason given'} (${job.error?.code ?? job.status})`);
      return;
    }
    showReport(job.id, job.report);
    await showMesh(job.id, job.report, atomsPromise);
  } catch (error) {
    setMessage(error.message);
    setPictureState('error');
  } finally {
    owner = null;
    $('cancel').disabled = true;
    $('submit').disabled = chosenFile === null;
  }
}

// ---- wiring ---------------------------------------------------------------------------------------------------

$('file').addEventListener('change', (event) => chooseFile(event.target.files[0]));
const dropZone = $('drop-zone');
window.addEventListener('dragover', (event) => {
  event.preventDefault();
  dropZone.classList.add('dragging');
});
window.addEventListener('dragleave', () => dropZone.classList.remove('dragging'));
window.addEventListener('drop', (event) => {
  event.preventDefault();
  dropZone.classList.remove('dragging');
  chooseFile(event.dataTransfer.files[0]);
});
$('job-form').addEventListener('submit', (event) => {
  event.preventDefault();
  if (chosenFile) runJob();
});
$('cancel').addEventListener('click', () => {
  if (owner) cancelJob(owner.id, owner.token).catch((error) => setMessage(error.message));
});
$('colour-mode').addEventListener('change', () => shown && applyColours());
$('outer-opacity').addEventListener('input', (event) => view.setOuterOpacity(Number(event.target.value)));
$('fit').addEventListener('click', () => view.fit());
viewer.ready = true;
