// The service's job API as the page uses it (docs/api.md, proto/openapi.json): submit, follow, cancel.

const finishedStates = new Set(['done', 'failed', 'cancelled']);
const pollIntervalMs = 500;

/// Error of a non-2xx reply: the JSON body's message when it has one ({"error": {"code", "message"}}).
async function replyError(response, what) {
  let detail = `HTTP ${response.status}`;
  try {
    const body = await response.json();
    if (body?.error?.message) detail = `${body.error.message} (${body.error.code}, HTTP ${response.status})`;
  } catch {
    // not JSON: the status says enough
  }
  return new Error(`${what}: ${detail}`);
}

/// POST /jobs with the file and the parameters as form fields; resolves to { id, status, token }.
/// The token (also in the X-Job-Token header) is what DELETE /jobs/{id} needs to withdraw this submission.
export async function submitJob(file, parameters) {
  const form = new FormData();
  for (const [name, value] of Object.entries(parameters)) form.append(name, value);
  form.append('structure', file, file.name);
  const response = await fetch('/jobs', { method: 'POST', body: form });
  if (!response.ok) throw await replyError(response, 'the job was refused');
  const accepted = await response.json();
  return { ...accepted, token: response.headers.get('X-Job-Token') ?? accepted.token };
}

/// DELETE /jobs/{id} with the owner token.
export async function cancelJob(id, token) {
  const response = await fetch(`/jobs/${id}`, { method: 'DELETE', headers: { 'X-Job-Token': token } });
  if (!response.ok) throw await replyError(response, 'cancelling failed');
}

async function fetchJob(id) {
  const response = await fetch(`/jobs/${id}`, { cache: 'no-store' });
  if (!response.ok) throw await replyError(response, `job ${id.slice(0, 12)}…`);
  return response.json();
}

/// Polls GET /jobs/{id} every 500 ms until the job is finished.
async function pollJob(id, onUpdate) {
  for (;;) {
    const job = await fetchJob(id);
    onUpdate(job);
    if (finishedStates.has(job.status)) return job;
    await new Promise((resolve) => setTimeout(resolve, pollIntervalMs));
  }
}

/// Follows a job until it is finished; calls onUpdate(job JSON) on every change; resolves to the final job JSON
/// (status done, failed or cancelled). Listens to GET /jobs/{id}/events (Server-Sent Events: `progress` events,
/// then one `done` or `error`); when that stream cannot be opened (a server without the route answers 404) or
/// breaks off, it polls GET /jobs/{id} instead.
export function followJob(id, onUpdate) {
  return new Promise((resolve, reject) => {
    const source = new EventSource(`/jobs/${id}/events`);
    const finish = (event) => {
      source.close();
      const job = JSON.parse(event.data);
      onUpdate(job);
      resolve(job);
    };
    source.addEventListener('progress', (event) => onUpdate(JSON.parse(event.data)));
    source.addEventListener('done', finish);
    source.addEventListener('error', (event) => {
      // The server's own `event: error` carries the job; EventSource's connection error carries nothing.
      if (event instanceof MessageEvent && event.data) return finish(event);
      source.close();
      pollJob(id, onUpdate).then(resolve, reject);
    });
  });
}

export function isFinished(job) {
  return finishedStates.has(job.status);
}
