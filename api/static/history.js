// Run history (state, joints, start, duration; watch, report, trace) and two identification
// runs of one joint side by side.
import * as api from "/static/api.js";
import {$, el, fmt, when, duration} from "/static/dom.js";

const PARAMS = ["Fc", "Fs", "alpha", "sigma0", "sigma1", "sigma2"];

export const runs = {
  init(ctx) { $("#history-refresh").onclick = () => refresh(ctx); },
  enter(ctx) { refresh(ctx); },
};

async function refresh(ctx) {
  try {
    const list = await api.get("/runs?limit=100");
    $("#history tbody").replaceChildren(...list.runs.map(r => row(ctx, r)));
    $("#history-msg").textContent = list.runs.length ? "" : "no runs yet";
  } catch (e) {
    $("#history-msg").textContent = e.message;
  }
}

function row(ctx, r) {
  const ended = ["succeeded", "failed", "cancelled", "interrupted"].includes(r.state);
  const fail = e => { $("#history-msg").textContent = e.message; };
  return el("tr", {"data-run": r.id},
    el("td", {}, el("a", {href: "#", onclick: ev => { ev.preventDefault(); ctx.go("live", r.id); }}, r.id)),
    el("td", {}, r.procedure), el("td", {title: r.error || ""}, r.state), el("td", {}, r.joints.join(", ")),
    el("td", {}, when(r.started)), el("td", {}, r.started ? duration(r.started, r.ended) : "–"),
    el("td", {}, ended ? [
      el("button", {type: "button", class: "report", onclick: () => api.openHtml(`/runs/${r.id}/report`).catch(fail)}, "report"),
      r.joints.map(j => [" ", el("button", {type: "button", class: "csv", "data-joint": j, onclick: () =>
        api.download(`/runs/${r.id}/trace.csv?joint=${encodeURIComponent(j)}`, `${r.id}-${j}.csv`).catch(fail)},
        `CSV ${j}`)]),
      // the trace into the Analyze view: diagnose it, add effects, watch the error fall (operators)
      r.joints.map(j => [" ", el("button", {type: "button", class: "analyze op-only", "data-joint": j,
        onclick: () => ctx.go("analyze", {run: r.id, joint: j})}, `analyze ${j}`)]),
    ] : ""));
}

// --- compare ---------------------------------------------------------------------------------
let cmpRuns = [];

export const compare = {
  init(ctx) {
    $("#cmp-joint").replaceChildren(...ctx.joints.map(j => el("option", {value: j}, j)));
    $("#cmp-joint").onchange = () => load();
    $("#cmp-a").onchange = $("#cmp-b").onchange = () => render();
  },
  enter() { load(); },
};

async function load() {
  const joint = $("#cmp-joint").value;
  try {
    const list = await api.get(`/runs?procedure=identify&state=succeeded&joint=${encodeURIComponent(joint)}&limit=50`);
    cmpRuns = list.runs.filter(r => r.result && r.result.joints && r.result.joints[joint]);
  } catch (e) {
    $("#compare-msg").textContent = e.message;
    return;
  }
  const opts = () => cmpRuns.map(r => el("option", {value: r.id}, `${when(r.started)} · ${r.id}`));
  $("#cmp-a").replaceChildren(...opts());
  $("#cmp-b").replaceChildren(...opts());
  if (cmpRuns.length > 1) { $("#cmp-a").value = cmpRuns[1].id; $("#cmp-b").value = cmpRuns[0].id; }   // older vs newer
  render();
}

function render() {
  const joint = $("#cmp-joint").value;
  const a = cmpRuns.find(r => r.id === $("#cmp-a").value), b = cmpRuns.find(r => r.id === $("#cmp-b").value);
  $("#compare-msg").textContent = cmpRuns.length < 2
    ? `${cmpRuns.length} succeeded identification run(s) of ${joint}: two are needed` : "";
  if (!a || !b) { $("#compare tbody").replaceChildren(); return; }
  const ja = a.result.joints[joint], jb = b.result.joints[joint];
  const pu = (j, k) => (j.uncertainty || {})[k];
  $("#compare tbody").replaceChildren(...PARAMS.map(k => {
    const va = ja.parameters[k], vb = jb.parameters[k];
    const change = typeof va === "number" && typeof vb === "number" && va !== 0 ? 100 * (vb - va) / Math.abs(va) : null;
    return el("tr", {"data-param": k}, el("td", {}, k), el("td", {}, fmt(va)), el("td", {class: "muted"}, fmt(pu(ja, k))),
      el("td", {}, fmt(vb)), el("td", {class: "muted"}, fmt(pu(jb, k))),
      el("td", {class: "change"}, change === null ? "–" : `${change >= 0 ? "+" : ""}${change.toFixed(1)} %`));
  }));
}
