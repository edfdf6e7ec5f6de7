// The page's only way to the bench: the REST API, with the key the technician typed.
// The key lives in sessionStorage (gone when the tab closes) and travels only in the
// Authorization header -- never in a URL, so it is in no server log or browser history.

// What the page polls and how often (ms), and the live sample rate it asks the event stream
// for.  benchmarks/bench_api.py reads this line to load the server as open pages would: keep
// it one line of JSON.
export const POLL = {"health_ms": 1000, "joints_ms": 2000, "run_ms": 2000, "sample_hz": 10};

const KEY = "bench.key";

export const session = {
  get key() { return sessionStorage.getItem(KEY); },
  set key(v) { if (v) sessionStorage.setItem(KEY, v); else sessionStorage.removeItem(KEY); },
};

export class ApiError extends Error {
  constructor(status, detail, errors) {
    super(detail);
    this.status = status;
    this.errors = errors || [];
  }
}

function headers(extra) {
  const h = Object.assign({}, extra || {});
  if (session.key) h["Authorization"] = "Bearer " + session.key;
  return h;
}

async function fail(r) {
  let detail = `HTTP ${r.status}`, errors = [];
  try {
    const body = await r.json();
    detail = body.detail || detail;
    errors = body.errors || [];
  } catch (e) { /* not JSON: keep the status line */ }
  return new ApiError(r.status, detail, errors);
}

// a FormData body goes as multipart (the browser sets its boundary), anything else as JSON
async function send(method, path, body, signal) {
  const form = body instanceof FormData;
  const init = {method, signal, headers: headers(body !== undefined && !form ? {"content-type": "application/json"} : {})};
  if (body !== undefined) init.body = form ? body : JSON.stringify(body);
  let r;
  try {
    r = await fetch(path, init);
  } catch (e) {
    if (signal && signal.aborted) throw new ApiError(0, "cancelled");
    throw new ApiError(0, "cannot reach the bench service (is bench serve running?)");
  }
  if (!r.ok) throw await fail(r);
  return r;
}

export async function get(path) { return (await send("GET", path)).json(); }

// A file POSTed as multipart/form-data (field "file": its name goes along); abort via `signal`.
export async function upload(path, file, signal) {
  const form = new FormData();
  form.append("file", file, file.name);
  return (await send("POST", path, form, signal)).json();
}
export async function post(path, body) { return (await send("POST", path, body)).json(); }
export async function put(path, body) { return (await send("PUT", path, body)).json(); }
export async function blob(path) { return (await send("GET", path)).blob(); }

// A run's server-sent events, read with fetch() so that the Authorization header goes along
// (EventSource cannot send headers).  Calls onEvent({event, id, data}) per event; resolves
// when the stream ends; abort through `signal`.
export async function events(path, onEvent, signal) {
  let r;
  try {
    r = await fetch(path, {headers: headers({"accept": "text/event-stream"}), signal});
  } catch (e) {
    if (signal && signal.aborted) return;
    throw new ApiError(0, "lost the bench service's event stream");
  }
  if (!r.ok) throw await fail(r);
  const reader = r.body.pipeThrough(new TextDecoderStream()).getReader();
  let buf = "";
  for (;;) {
    let chunk;
    try {
      chunk = await reader.read();
    } catch (e) {
      if (signal && signal.aborted) return;
      throw new ApiError(0, "lost the bench service's event stream");
    }
    if (chunk.done) return;
    buf += chunk.value;
    let cut;
    while ((cut = buf.indexOf("\n\n")) >= 0) {
      const block = buf.slice(0, cut);
      buf = buf.slice(cut + 2);
      const ev = {event: "message", id: null, data: null};
      for (const line of block.split("\n")) {
        if (line.startsWith("event:")) ev.event = line.slice(6).trim();
        else if (line.startsWith("id:")) ev.id = parseInt(line.slice(3), 10);
        else if (line.startsWith("data:")) ev.data = JSON.parse(line.slice(5));
      }
      onEvent(ev);
    }
  }
}

// Save or show something fetched with the key: a Blob URL, so the key stays out of the URL.
export async function download(path, filename) {
  save(await blob(path), filename);
}

// Save a Blob the page already holds (an analysis's residuals) as a file.
export function save(b, filename) {
  const url = URL.createObjectURL(b);
  const a = document.createElement("a");
  a.href = url;
  a.download = filename;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
}

// The tab is opened at once (still inside the click, so no pop-up blocker objects) and
// shown the report when it has arrived.
export async function openHtml(path) {
  const w = window.open("", "_blank");
  try {
    const b = await blob(path);
    const url = URL.createObjectURL(new Blob([b], {type: "text/html"}));
    if (w) w.location.href = url;
    setTimeout(() => URL.revokeObjectURL(url), 60000);
  } catch (e) {
    if (w) w.close();
    throw e;
  }
}
