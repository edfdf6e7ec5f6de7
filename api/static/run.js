// Starting a run (the API's 422 messages next to the field at fault) and watching one live:
// progress, stages, excitation trials and their decisions, a plot of q, v and τ from the
// event stream; cancel; the report and trace once it has ended.
import * as api from "/static/api.js";
import {$, el, fmt} from "/static/dom.js";
import {LivePlot} from "/static/plot.js";

const FINAL = ["succeeded", "failed", "cancelled", "interrupted"];
const NUMBERS = ["seed", "search_max_trials", "search_cycles", "tracking_period", "tracking_cycles"];

// --- start -----------------------------------------------------------------------------------
export const start = {
  init(ctx) {
    $("#start-joints").replaceChildren(...ctx.joints.map(j =>
      el("label", {}, el("input", {type: "checkbox", name: "joint", value: j}), ` ${j} `)));
    const form = $("#start-form");
    form.onsubmit = ev => { ev.preventDefault(); submit(ctx, form); };
    form.procedure.onchange = () => { $("#calib-note").hidden = form.procedure.value !== "calibrate"; };
  },
};

function clearErrors() {
  for (const e of document.querySelectorAll("#start-form .field-error")) e.textContent = "";
  $("#start-msg").textContent = "";
}

// "body.options.search_max_trials" (validation) or "joints: ..." (the run manager) -> the field
function fieldOf(name) {
  const f = name.replace(/^body\./, "");
  return document.querySelector(`#start-form .field-error[data-field="${CSS.escape(f)}"]`)
    || document.querySelector(`#start-form .field-error[data-field="${CSS.escape(f.split(".").slice(0, 2).join("."))}"]`);
}

function request(form) {
  const body = {procedure: form.procedure.value, options: {}};
  const joints = [...form.querySelectorAll("input[name=joint]:checked")].map(b => b.value);
  if (joints.length || body.procedure !== "calibrate") body.joints = joints;
  for (const k of NUMBERS) {
    const raw = form[k].value.trim();
    // what was typed goes to the API as typed when it is not a number: the API says what is wrong
    if (raw !== "") body.options[k] = isFinite(Number(raw)) ? Number(raw) : raw;
  }
  if (!form.plots.checked) body.options.plots = false;
  if (form.compensation.value) body.options.compensation = form.compensation.value;
  if (form.model.value.trim()) body.options.model = form.model.value.trim();
  return body;
}

async function submit(ctx, form) {
  clearErrors();
  const button = $("#start-run");
  button.disabled = true;
  try {
    const created = await api.post("/runs", request(form));
    ctx.go("live", created.id);
  } catch (e) {
    let placed = false;
    for (const fe of e.errors) {
      const target = fieldOf(fe.field);
      if (target) { target.textContent = fe.message; placed = true; }
    }
    if (!placed) {
      const m = /^([a-z_.]+): (.*)$/.exec(e.message);     // "joints: give at least one joint id"
      const target = m ? fieldOf(m[1]) : null;
      if (target) target.textContent = m[2];
      else $("#start-msg").textContent = e.message;       // 409 (busy, e-stop), 403, ...
    }
  } finally {
    button.disabled = false;
  }
}

// --- live ------------------------------------------------------------------------------------
let plot = null;
let watch = null;        // {id, abort, timer, info}

export const live = {
  init(ctx) {
    plot = new LivePlot($("#plot"));
    $("#live-joint").onchange = ev => plot.show(ev.target.value);
    $("#live-cancel").onclick = () => act(() => api.post(`/runs/${watch.id}/cancel`));
    $("#live-report").onclick = () => act(() => api.openHtml(`/runs/${watch.id}/report${jointQuery()}`));
    $("#live-csv").onclick = () => act(() =>
      api.download(`/runs/${watch.id}/trace.csv${jointQuery()}`, `${watch.id}-${$("#live-joint").value}.csv`));
  },
  async enter(ctx, runId) {
    if (!runId) {
      if (watch) { plot.draw(); return; }              // back to the run being watched
      const runs = await api.get("/runs?limit=1").catch(() => ({runs: []}));
      if (!runs.runs.length) { $("#live-msg").textContent = "no run yet"; return; }
      runId = runs.runs[0].id;
    }
    if (watch && watch.id === runId) return;
    follow(ctx, runId);
  },
};

function jointQuery() {
  const j = $("#live-joint").value;
  return j ? `?joint=${encodeURIComponent(j)}` : "";
}

async function act(fn) {
  try { await fn(); $("#live-msg").textContent = ""; } catch (e) { $("#live-msg").textContent = e.message; }
}

function stop() {
  if (!watch) return;
  watch.abort.abort();
  clearTimeout(watch.timer);
  watch = null;
}

async function follow(ctx, runId) {
  stop();
  const w = watch = {id: runId, abort: new AbortController(), timer: null, info: null, last: -1, ended: false};
  $("#live-id").textContent = runId;
  $("#stages").replaceChildren();
  $("#results").replaceChildren(el("li", {class: "muted"}, "none yet"));
  $("#trials tbody").replaceChildren();
  $("#live-msg").textContent = "";
  let info;
  try {
    info = await api.get(`/runs/${runId}`);
  } catch (e) {
    $("#live-msg").textContent = e.message;
    return;
  }
  const joints = info.joints;
  $("#live-joint").replaceChildren(...joints.map(j => el("option", {value: j}, j)));
  plot.reset(joints);
  showInfo(w, info);
  pollRun(w);
  stream(w);
}

// the run's state and progress every POLL.run_ms, also when the stream is down
async function pollRun(w) {
  if (watch !== w) return;
  try {
    showInfo(w, await api.get(`/runs/${w.id}`));
  } catch (e) {
    $("#live-msg").textContent = e.message;
  }
  if (watch === w && !w.ended) w.timer = setTimeout(() => pollRun(w), api.POLL.run_ms);
}

function showInfo(w, info) {
  w.info = info;
  const ended = FINAL.includes(info.state);
  const state = $("#live-state");
  state.textContent = `${info.procedure} · ${info.state}` + (info.error ? ` — ${info.error}` : "");
  state.className = "pill " + (info.state === "succeeded" ? "good" : ["failed", "interrupted"].includes(info.state) ? "bad" : "");
  setProgress(info.progress);
  $("#live-cancel").hidden = ended;
  $("#live-report").hidden = !ended;
  $("#live-csv").hidden = !ended;
  w.ended = ended;
}

function setProgress(p) {
  $("#live-progress").value = p;
  $("#live-pct").textContent = `${Math.round(100 * p)} %`;
}

async function stream(w) {
  // reconnects after a drop, resuming after the last event seen, until the run has ended
  while (watch === w) {
    try {
      await api.events(`/runs/${w.id}/events?after=${w.last}&sample_hz=${api.POLL.sample_hz}`,
        ev => onEvent(w, ev), w.abort.signal);
    } catch (e) {
      if (watch === w) $("#live-msg").textContent = e.message;
    }
    if (watch !== w || w.ended) return;
    const info = await api.get(`/runs/${w.id}`).catch(() => null);
    if (info) showInfo(w, info);
    if (w.ended) return;
    await new Promise(r => setTimeout(r, 1000));
  }
}

function onEvent(w, ev) {
  if (watch !== w) return;
  if (ev.id !== null && !isNaN(ev.id)) w.last = ev.id;
  const d = ev.data && ev.data.data ? ev.data.data : ev.data || {};
  switch (ev.event) {
    case "sample": plot.add(ev.data.samples || {}); break;
    case "progress": setProgress(ev.data.progress); break;
    case "stage": addStage(d); break;
    case "retry": addStage({joint: d.joint, stage: d.stage, status: `retry: ${d.reason}`}); break;
    case "trial": addTrial(d); break;
    case "model":
      addResult(`${d.joint} model ${d.model_id}: ` +
        Object.entries(d.parameters || {}).map(([k, v]) => `${k} ${fmt(v)}`).join(" · "));
      break;
    case "tracking":
      addResult(`${d.joint} tracking, ${d.variant}: rms error ${fmt(d.rms_error)}, max ${fmt(d.max_error)}`);
      break;
    case "end":
      api.get(`/runs/${w.id}`).then(info => showInfo(w, info)).catch(() => {});
      break;
  }
}

function addStage(d) {
  const key = `${d.joint}/${d.stage}`;
  const text = `${d.joint} · ${d.stage}: ${d.status}` + (d.reason ? ` (${d.reason})` : "");
  const old = document.querySelector(`#stages li[data-key="${CSS.escape(key)}"]`);
  if (old) old.textContent = text;
  else $("#stages").append(el("li", {"data-key": key}, text));
}

function addResult(text) {
  for (const old of document.querySelectorAll("#results li.muted")) old.remove();
  $("#results").append(el("li", {}, text));
}

function addTrial(t) {
  $("#trials tbody").append(el("tr", {class: "trial"},
    el("td", {}, t.joint), el("td", {}, t.index), el("td", {}, fmt(t.amplitude)), el("td", {}, fmt(t.frequency)),
    el("td", {}, el("span", {class: "decision-" + t.outcome}, t.outcome), t.reason ? ` — ${t.reason}` : "")));
  const side = document.querySelector(".side");
  side.scrollTop = side.scrollHeight;
}
