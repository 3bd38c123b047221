// The web viewer in a real browser against the real tracemeshd (ctest web.viewer).
//   node tests/node/web_viewer_test.mjs --tracemeshd BIN --molecules DIR [--screenshot OUT.png] [--molecule FILE]
//                                       [--density 1] [--measure]
// Starts tracemeshd on a loopback port, opens `/` in headless Chromium (Debian's, driven by playwright-core; WebGL
// on SwiftShader), uploads the molecule (fas2.pqr), waits for the picture and checks:
//   - the canvas shows the mesh (share of pixels that differ from the background, in a screenshot);
//   - every number of the report panel equals GET /jobs/{id}'s report (to the digits shown);
//   - the documented snippets (web/snippets/*.js, run as they are) read the atom index of every vertex from the GLB
//     (GLTFLoader + DRACOLoader) and from the raw .drc (DRACOLoader with a custom attribute map), and each equals
//     the atom index of the vertex at the same position in the PLY of the same job;
//   - no console error, page error or failed request happened.
// --measure: only load the molecule and print the times (submit → job done → mesh decoded → first frame) and the
// longest main-thread task while the mesh was loaded; --colour MODE and --opacity X set the view of the screenshot.
// Exits 0 on success, 1 on a failure, 77 (ctest SKIP_RETURN_CODE) when no Chromium is installed.
import { spawn } from 'node:child_process';
import { existsSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { createInterface } from 'node:readline';
import { fileURLToPath } from 'node:url';
import { parseArgs } from 'node:util';

const { values: options } = parseArgs({
  options: {
    tracemeshd: { type: 'string' },
    molecules: { type: 'string' },
    molecule: { type: 'string', default: 'fas2.pqr' },
    density: { type: 'string', default: '1' },
    screenshot: { type: 'string' },
    measure: { type: 'boolean', default: false },
    colour: { type: 'string' },   // with --measure: the colour mode of the screenshot
    opacity: { type: 'string' },  // with --measure: the outer surface's opacity in the screenshot
  },
});
if (!options.tracemeshd || !options.molecules) {
  console.error('usage: web_viewer_test.mjs --tracemeshd BIN --molecules DIR [--screenshot OUT.png] [--molecule FILE] [--measure]');
  process.exit(2);
}
// $CHROMIUM names the browser explicitly (and only it); otherwise Debian's.
const chromiumPath = (process.env.CHROMIUM ? [process.env.CHROMIUM] : ['/usr/bin/chromium', '/usr/bin/chromium-browser'])
  .find((path) => existsSync(path));
if (!chromiumPath) {
  console.log('SKIP: no Chromium (apt-get install chromium; scripts/install-deps.sh installs it)');
  process.exit(77);
}
const repo = join(dirname(fileURLToPath(import.meta.url)), '..', '..');
const { chromium } = await import('playwright-core');
const { PNG } = await import('pngjs');
const esbuild = await import('esbuild');

const failures = [];
const check = (condition, message) => {
  if (!condition) failures.push(message);
};

/// tracemeshd on an ephemeral loopback port; resolves once its "started" log line names the port.
function startServer() {
  const server = spawn(options.tracemeshd, ['--listen', '127.0.0.1:0', '--no-disk-store', '--workers', '2'],
    { stdio: ['ignore', 'pipe', 'pipe'] });
  const log = [];
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`tracemeshd did not start:\n${log.join('\n')}`)), 10000);
    for (const stream of [server.stdout, server.stderr]) {
      createInterface({ input: stream }).on('line', (line) => {
        log.push(line);
        if (!line.includes('"event":"started"')) return;
        clearTimeout(timer);
        resolve({ process: server, url: `http://127.0.0.1:${JSON.parse(line).port}`, log });
      });
    }
    server.on('exit', (code) => reject(new Error(`tracemeshd exited (${code}):\n${log.join('\n')}`)));
  });
}

/// Vertices of a binary little-endian PLY: { positions: Float32Array (3 per vertex), atomIndex: Uint32Array }.
function readPly(bytes) {
  const headerEnd = bytes.indexOf('end_header\n') + 'end_header\n'.length;
  const header = bytes.subarray(0, headerEnd).toString('latin1').split('\n');
  const sizes = { float: 4, uint: 4, int: 4, uchar: 1, double: 8 };
  let count = 0;
  const properties = [];
  let inVertex = false;
  for (const line of header) {
    const words = line.trim().split(/\s+/);
    if (words[0] === 'element') {
      inVertex = words[1] === 'vertex';
      if (inVertex) count = Number(words[2]);
    } else if (words[0] === 'property' && inVertex) {
      properties.push({ type: words[1], name: words[2] });
    }
  }
  const stride = properties.reduce((sum, p) => sum + sizes[p.type], 0);
  const view = new DataView(bytes.buffer, bytes.byteOffset + headerEnd);
  const positions = new Float32Array(3 * count);
  const atomIndex = new Uint32Array(count);
  for (let v = 0; v < count; ++v) {
    let offset = v * stride;
    for (const p of properties) {
      if (p.name === 'x' || p.name === 'y' || p.name === 'z') {
        positions[3 * v + 'xyz'.indexOf(p.name)] = view.getFloat32(offset, true);
      } else if (p.name === 'atom_index') {
        atomIndex[v] = view.getUint32(offset, true);
      }
      offset += sizes[p.type];
    }
  }
  return { positions, atomIndex };
}

/// Every decoded vertex has a PLY vertex within `tolerance` Å (Draco quantises positions to ≤ 0.01 Å) with the
/// same atom index; returns the number of mismatches (and reports the first few).
function compareAtomIndices(what, decoded, reference, tolerance = 0.02) {
  const cell = 0.05;
  // Cells by integer index: neighbours found as index ± 1, not as the cell of (x ± cell), which rounding can skip
  // (z = 24.25 − 0.05 falls in cell 483, not 484).
  const cellOf = (x, y, z) => [Math.floor(x / cell), Math.floor(y / cell), Math.floor(z / cell)];
  const key = ([i, j, k]) => `${i},${j},${k}`;
  const grid = new Map();
  const count = reference.atomIndex.length;
  for (let v = 0; v < count; ++v) {
    const p = reference.positions.subarray(3 * v, 3 * v + 3);
    const k = key(cellOf(p[0], p[1], p[2]));
    if (!grid.has(k)) grid.set(k, []);
    grid.get(k).push(v);
  }
  check(decoded.atomIndex.length === count, `${what}: ${decoded.atomIndex.length} vertices, the PLY has ${count}`);
  let mismatches = 0;
  for (let v = 0; v < decoded.atomIndex.length; ++v) {
    const [x, y, z] = decoded.positions.slice(3 * v, 3 * v + 3);
    let best = -1;
    let bestDistance = Infinity;
    const [i, j, k] = cellOf(x, y, z);
    for (let dx = -1; dx <= 1; ++dx) for (let dy = -1; dy <= 1; ++dy) for (let dz = -1; dz <= 1; ++dz) {
      for (const r of grid.get(key([i + dx, j + dy, k + dz])) ?? []) {
        const d = Math.hypot(reference.positions[3 * r] - x, reference.positions[3 * r + 1] - y, reference.positions[3 * r + 2] - z);
        if (d < bestDistance) [best, bestDistance] = [r, d];
      }
    }
    if (bestDistance > tolerance || reference.atomIndex[best] !== decoded.atomIndex[v]) {
      if (++mismatches <= 3) {
        failures.push(`${what}: vertex ${v} at (${x}, ${y}, ${z}) has atom ${decoded.atomIndex[v]}; the PLY's nearest ` +
          `vertex (${bestDistance.toFixed(4)} Å away) has atom ${reference.atomIndex[best]}`);
      }
    }
  }
  check(mismatches === 0, `${what}: ${mismatches} of ${decoded.atomIndex.length} vertices differ from the PLY`);
  return mismatches;
}

/// The snippets bundled as they are (imports resolved from node_modules; one esbuild run parses three.js once), for
/// the page to import from /test-snippets/ (answered by the test itself through page.route: the snippets are
/// documentation, not part of the server). Resolves to { file name: code }.
async function bundleSnippets(names) {
  const result = await esbuild.build({
    entryPoints: names.map((name) => join(repo, 'web', 'snippets', name)),
    bundle: true, format: 'esm', write: false, outdir: 'snippets', logLevel: 'error',
  });
  return Object.fromEntries(result.outputFiles.map((file) => [file.path.split('/').pop(), file.text]));
}

/// Share of the canvas's pixels that differ clearly from the background colour (#f4f5f7).
function foregroundShare(png) {
  const image = PNG.sync.read(png);
  let foreground = 0;
  for (let i = 0; i < image.data.length; i += 4) {
    const d = Math.abs(image.data[i] - 0xf4) + Math.abs(image.data[i + 1] - 0xf5) + Math.abs(image.data[i + 2] - 0xf7);
    if (d > 24) ++foreground;
  }
  return foreground / (image.width * image.height);
}

/// The number shown in a report cell, or the text when it is not a number; with the digits after the point.
function shownValue(text) {
  const plain = text.replaceAll(',', '');
  if (!/^-?\d+(\.\d+)?$/.test(plain)) return { text };
  return { number: Number(plain), digits: plain.includes('.') ? plain.split('.')[1].length : 0 };
}

function reportValue(report, path) {
  const value = path.split('.').reduce((node, key) => node?.[key], report);
  return Array.isArray(value) ? value.length : value;
}

const server = await startServer();
const browser = await chromium.launch({
  executablePath: chromiumPath,
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});
const started = Date.now();
try {
  const page = await browser.newPage({ viewport: { width: 1100, height: 700 } });
  const problems = [];
  // Until the events route (GET /jobs/{id}/events) is in this server, the page's EventSource gets 404 and polls:
  // that one 404 is expected when openapi.json does not list the route, and nothing else.
  const openapi = await (await fetch(`${server.url}/openapi.json`)).json();
  const eventsRouteServed = '/jobs/{id}/events' in openapi.paths;
  const expected404 = (url) => !eventsRouteServed && /\/jobs\/[0-9a-f]{64}\/events$/.test(url);
  page.on('console', (message) => {
    if (message.type() !== 'error' && message.type() !== 'warning') return;
    if (expected404(message.location().url)) return;
    // Each snippet bundle carries its own copy of three.js next to the viewer's, and three.js says so.
    if (message.location().url.includes('/test-snippets/') && message.text().includes('Multiple instances of Three.js')) return;
    problems.push(`console ${message.type()}: ${message.text()} (${message.location().url})`);
  });
  page.on('pageerror', (error) => problems.push(`page error: ${error.message}`));
  // The page closes a job's EventSource itself once the final event came or the job was cancelled (else the browser
  // would reconnect when the server ends the stream): Chromium reports that as an aborted request, which is no error.
  const closedByThePage = (request) =>
    /\/jobs\/[0-9a-f]{64}\/events$/.test(request.url()) && request.failure()?.errorText === 'net::ERR_ABORTED';
  page.on('requestfailed', (request) => {
    if (expected404(request.url()) || closedByThePage(request)) return;
    problems.push(`request failed: ${request.url()} ${request.failure()?.errorText}`);
  });
  const jobPolls = [];  // GET /jobs/{id}: the page's fallback when the events stream is not there
  page.on('request', (request) => {
    if (/\/jobs\/[0-9a-f]{64}$/.test(new URL(request.url()).pathname) && request.method() === 'GET') jobPolls.push(request.url());
  });
  page.on('response', (response) => {
    if (response.status() >= 400 && !expected404(response.url())) problems.push(`HTTP ${response.status()}: ${response.url()}`);
  });
  await page.addInitScript(() => {
    window.longestTaskMs = 0;
    new PerformanceObserver((list) => {
      for (const entry of list.getEntries()) window.longestTaskMs = Math.max(window.longestTaskMs, entry.duration);
    }).observe({ type: 'longtask', buffered: true });
  });

  await page.goto(`${server.url}/`);
  await page.waitForFunction(() => window.tracemeshViewer?.ready === true);
  await page.setInputFiles('#file', join(options.molecules, options.molecule));
  await page.fill('input[name=density]', options.density);
  await page.evaluate(() => { window.longestTaskMs = 0; });
  await page.click('#submit');
  await page.waitForSelector('#picture-status[data-state=shown], #picture-status[data-state=error], #message:not(:empty)',
    { state: 'attached', timeout: options.measure ? 600000 : 60000 });
  const state = await page.$eval('#picture-status', (element) => element.dataset.state);
  if (state !== 'shown') throw new Error(`no picture: ${await page.textContent('#message')}`);
  const viewer = await page.evaluate(() => ({ ...window.tracemeshViewer, longestTaskMs: window.longestTaskMs }));
  const times = viewer.times;
  const ms = (from, to) => `${(times[to] - times[from]).toFixed(0)} ms`;
  console.log(`${options.molecule}: submit → job done ${ms('submitted', 'finished')}, GLB downloaded ` +
    `${ms('finished', 'meshDownloaded')}, decoded ${ms('meshDownloaded', 'meshDecoded')}, first frame ` +
    `${ms('meshDecoded', 'firstFrame')}; submit → first ` +
    `frame ${ms('submitted', 'firstFrame')}; longest main-thread task ${viewer.longestTaskMs.toFixed(0)} ms`);

  if (options.measure) {
    // Orbiting: frames drawn while the mouse drags across the canvas for ~2 s.
    const box = await page.locator('#canvas').boundingBox();
    await page.evaluate(() => {
      window.frameTimes = [];
      const tick = (time) => { window.frameTimes.push(time); if (window.frameTimes.length < 1000) requestAnimationFrame(tick); };
      requestAnimationFrame(tick);
    });
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
    await page.mouse.down();
    const dragStarted = Date.now();
    for (let step = 1; Date.now() - dragStarted < 2000; ++step) {
      await page.mouse.move(box.x + box.width / 2 + 3 * step, box.y + box.height / 2 + step);
    }
    await page.mouse.up();
    const frames = await page.evaluate(() => window.frameTimes.slice(1).map((t, i) => t - window.frameTimes[i]));
    frames.sort((a, b) => a - b);
    console.log(`orbiting: ${frames.length} frames in ~2 s, median ${frames[frames.length >> 1]?.toFixed(0)} ms, ` +
      `slowest ${frames.at(-1)?.toFixed(0)} ms (SwiftShader: WebGL on the CPU)`);
    await page.click('#fit');
  }
  if (options.colour) await page.selectOption('#colour-mode', options.colour);
  if (options.opacity) await page.fill('#outer-opacity', options.opacity);
  const canvasPng = await page.locator('#canvas').screenshot();
  const share = foregroundShare(canvasPng);
  console.log(`canvas: ${(100 * share).toFixed(1)}% of the pixels show the mesh`);
  check(share > 0.05, `the canvas is (almost) empty: ${(100 * share).toFixed(2)}% of its pixels differ from the background`);
  if (options.screenshot) await page.screenshot({ path: options.screenshot });

  if (!options.measure) {
    const id = viewer.jobId;
    const job = await (await fetch(`${server.url}/jobs/${id}`)).json();
    check(job.status === 'done', `GET /jobs/${id}: status ${job.status}`);
    // The page follows the job by Server-Sent Events where the server has them, and polls only where it has not.
    if (eventsRouteServed) check(jobPolls.length === 0, `the page polled GET /jobs/{id} ${jobPolls.length} times although the events route is served`);
    else check(jobPolls.length >= 1, 'without the events route the page never polled GET /jobs/{id}');
    const cells = await page.$$eval('#report dd[data-field]', (dds) => dds.map((dd) => ({ field: dd.dataset.field, text: dd.textContent })));
    check(cells.length >= 12, `the report panel shows ${cells.length} values`);
    for (const field of ['certificate.certified', 'vertices', 'triangles', 'area', 'volume', 'components', 'genus', 'timings.total']) {
      check(cells.some((cell) => cell.field === field), `the report panel does not show ${field}`);
    }
    for (const { field, text } of cells) {
      const expected = reportValue(job.report, field);
      const shown = shownValue(text);
      if (shown.number === undefined) {
        const expectedText = typeof expected === 'boolean' ? (expected ? 'yes' : 'NO') : String(expected);
        check(text === expectedText, `report ${field}: the page shows "${text}", GET /jobs/{id} says ${JSON.stringify(expected)}`);
      } else {
        check(Math.abs(shown.number - expected) <= 0.5 * 10 ** -shown.digits + 1e-9,
          `report ${field}: the page shows ${text}, GET /jobs/{id} says ${expected}`);
      }
    }
    const downloads = await page.$$eval('#downloads a', (links) => links.map((link) => link.getAttribute('href')));
    check(JSON.stringify(downloads) === JSON.stringify(['off', 'draco', 'glb', 'glb-raw', 'ply'].map((f) => `/jobs/${id}/mesh?format=${f}`)),
      `download links: ${JSON.stringify(downloads)}`);
    // The PQR was read in the page with the server's atom count, so charge and residue colours are offered.
    const enabledModes = await page.$$eval('#colour-mode option:not([disabled])', (options) => options.map((o) => o.value));
    check(['component', 'residue', 'charge'].every((mode) => enabledModes.includes(mode)), `colour modes offered: ${enabledModes}`);
    check(viewer.atomCount === job.report.atoms_meshed + job.report.zero_radius_atoms,
      `the page read ${viewer.atomCount} atoms, the server ${job.report.atoms_meshed + job.report.zero_radius_atoms}`);
    await page.selectOption('#colour-mode', 'charge');
    const chargePng = await page.locator('#canvas').screenshot();
    check(!chargePng.equals(canvasPng), 'colouring by charge did not change the picture');

    // The snippets, as documented, in this page (served by tracemeshd, under its Content-Security-Policy).
    const reference = readPly(Buffer.from(await (await fetch(`${server.url}/jobs/${id}/mesh?format=ply`)).arrayBuffer()));
    check(reference.atomIndex.length === job.report.vertices, `the PLY has ${reference.atomIndex.length} vertices`);
    const snippets = await bundleSnippets(['glb_atom_index.js', 'drc_atom_index.js']);
    await page.route('**/test-snippets/*.js', (route) => route.fulfill({
      contentType: 'text/javascript', body: snippets[new URL(route.request().url()).pathname.split('/').pop()],
    }));
    const decoded = await page.evaluate(async ({ id }) => {
      const load = (name) => import(`/test-snippets/${name}`);
      const decoderPath = new URL('./', document.querySelector('script[src$="viewer.js"]').src).href;
      const glb = await load('glb_atom_index.js');
      const fromGlb = await glb.loadTracemeshGlb(glb.createTracemeshGltfLoader(decoderPath), `/jobs/${id}/mesh?format=glb`);
      const drc = await load('drc_atom_index.js');
      const fromDrc = await drc.decodeTracemeshDrc(`/jobs/${id}/mesh?format=draco`, decoderPath);
      return {
        glb: { positions: [...fromGlb.geometry.getAttribute('position').array], atomIndex: [...fromGlb.atomIndex] },
        drc: { positions: [...fromDrc.getAttribute('position').array], atomIndex: [...fromDrc.getAttribute('atom_index').array] },
      };
    }, { id });
    compareAtomIndices('GLB _ATOM_INDEX (GLTFLoader)', decoded.glb, reference);
    compareAtomIndices('.drc atom_index (DRACOLoader)', decoded.drc, reference);
    const distinctAtoms = new Set(decoded.drc.atomIndex).size;
    check(distinctAtoms > 100, `only ${distinctAtoms} distinct atoms in the .drc's atom_index`);

    // Cancel withdraws the submission with its owner token (X-Job-Token): a larger job, cancelled as soon as it
    // is accepted, ends cancelled and the page says so.
    await page.setInputFiles('#file', join(options.molecules, 'mache.pqr'));
    await page.fill('input[name=density]', '4');
    await page.click('#submit');
    await page.waitForSelector('#cancel:not([disabled])', { timeout: 10000 });
    const cancelledId = await page.evaluate(() => window.tracemeshViewer.jobId);
    await page.click('#cancel');
    await page.waitForSelector('#picture-status[data-state=cancelled]', { state: 'attached', timeout: 20000 });
    check((await page.textContent('#message')).includes('cancelled'), `after Cancel the page says "${await page.textContent('#message')}"`);
    const cancelled = await (await fetch(`${server.url}/jobs/${cancelledId}`)).json();
    check(cancelled.status === 'cancelled', `after Cancel GET /jobs/{id} says ${cancelled.status}`);
  }
  for (const problem of problems) failures.push(problem);
} catch (error) {
  failures.push(error.stack ?? String(error));
} finally {
  await browser.close();
  server.process.kill('SIGKILL');
}
console.log(`${failures.length === 0 ? 'PASS' : 'FAIL'} in ${((Date.now() - started) / 1000).toFixed(1)} s`);
for (const failure of failures) console.log(`  ${failure}`);
process.exit(failures.length === 0 ? 0 : 1);
