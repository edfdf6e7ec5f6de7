// Analyze a log: upload a record or a friction-velocity map (POST /analyze), see the model
// beside the measurement and what the diagnosis says is missing, tick an effect, analyse
// again, and watch the held-out error fall (the table of this tab's analyses).
import * as api from "/static/api.js";
import {$, el, fmt} from "/static/dom.js";

// the form's fields that are POST /analyze's query parameters as they are
const FIELDS = ["columns", "joint", "inertia", "joint_type", "position_unit", "torque_unit", "time_unit",
                "sample_rate", "window", "torque_hold", "encoder"];
const PNG = "data:image/png;base64,";
// the plots in the order a technician reads them: the fit, where it fails, each effect's step,
// the error falling; then the presliding and the inertia's sensitivity.  Panels of several
// plots ("wide") take the full width.
const PLOTS = [["map", "Friction-velocity map: the LuGre fit"], ["friction_map", "Friction-velocity map"],
               ["residual_baseline", "Where LuGre alone fails", "wide"], ["step", "Step", "wide"],
               ["error_fall", "Held-out error as effects are added"], ["presliding", "Presliding"],
               ["inertia", "The inertia's effect on the map (Fig. 2)"]];
let abort = null;
let runs = 0;
let pending = null;     // a run's trace brought from the history, analysed in place of a chosen file
let residuals = null;   // the last analysis's residuals CSV {text, name}, saved on request

export const view = {
  init() {
    $("#analyze-form").onsubmit = ev => { ev.preventDefault(); analyze(); };
    $("#an-cancel").onclick = () => { if (abort) abort.abort(); };
    $("#an-residuals").onclick = () => {
      if (residuals) api.save(new Blob([residuals.text], {type: "text/csv"}), residuals.name);
    };
    $("#an-file").onchange = () => { pending = null; $("#an-trace").textContent = ""; };
    loadEffects();
  },
  // from the history: {run, joint}, the run's trace of that joint (a record with its metadata)
  async enter(ctx, arg) {
    if (!arg || !arg.run) return;
    $("#an-msg").textContent = "";
    $("#an-file").value = "";
    try {
      const blob = await api.blob(`/runs/${encodeURIComponent(arg.run)}/trace.csv?joint=${encodeURIComponent(arg.joint)}`);
      pending = new File([blob], `${arg.run}-${arg.joint}.csv`, {type: "text/csv"});
      $("#an-trace").textContent = `the trace of ${arg.joint} in run ${arg.run} (${(blob.size / 1e6).toFixed(1)} MB)`;
    } catch (e) {
      pending = null;
      $("#an-trace").textContent = "";
      $("#an-msg").textContent = e.message;
    }
  },
};

async function loadEffects() {
  try {
    const list = await api.get("/effects");
    $("#an-effects").replaceChildren(...list.effects.map(e =>
      el("label", {title: e.summary + (e.on_maps ? "" : " (not on a friction-velocity map)")},
         el("input", {type: "checkbox", name: "add", value: e.name}), " ", e.name)));
  } catch (e) {
    $("#an-effects").textContent = `the effect library could not be listed: ${e.message}`;
  }
}

function query() {
  const form = $("#analyze-form");
  const q = new URLSearchParams();
  for (const f of FIELDS) {
    const v = form.elements[f].value.trim();
    if (v) q.set(f, v);
  }
  const add = [...form.querySelectorAll("input[name=add]:checked")].map(c => c.value);
  if (add.length) q.set("add", add.join(","));
  if (!form.elements.diagnose.checked) q.set("diagnose", "false");
  q.set("plots", "true");
  q.set("residuals", "true");     // bench analyze --residuals: the comparison at the file's own times
  return q;
}

async function analyze() {
  const file = pending || $("#an-file").files[0];
  $("#an-msg").textContent = "";
  if (!file) { $("#an-msg").textContent = "Choose a log file first (or a run's trace from the history)."; return; }
  const q = query();
  abort = new AbortController();
  const started = Date.now();
  const tick = setInterval(() => { $("#an-busy").textContent = `analysing ${file.name}… ${((Date.now() - started) / 1000).toFixed(0)} s`; }, 500);
  $("#an-run").disabled = true;
  $("#an-cancel").hidden = false;
  try {
    const doc = await api.upload(`/analyze?${q}`, file, abort.signal);
    show(doc, file.name, q.get("add") || "");
    residuals = {text: doc.residuals_csv, name: file.name.replace(/\.[^.]*$/, "") + "-residuals.csv"};
    $("#an-residuals").hidden = !doc.residuals_csv;
  } catch (e) {
    // the API's one line (422: what is wrong with the file or the options; 413: too large)
    $("#an-msg").textContent = e.message;
  } finally {
    clearInterval(tick);
    abort = null;
    $("#an-busy").textContent = "";
    $("#an-run").disabled = false;
    $("#an-cancel").hidden = true;
  }
}

function show(doc, name, added) {
  $("#an-result").hidden = false;
  const left = doc.unexplained || null;
  const named = (doc.diagnosis || []).filter(d => d.significant).map(d => d.effect);
  const verdict = !left ? "Not diagnosed (diagnose is off)"
    : left.structured ? "Still unexplained: physics the model does not hold"
    : named.length ? `Named: ${named.join(", ")}; nothing left to explain` : "Nothing left to explain";
  $("#an-verdict").textContent = (doc.record === "friction_map" ? "Friction-velocity map. " : "") + verdict;
  $("#an-verdict").className = left && left.structured ? "error" : "";
  $("#an-evidence").textContent = left ? left.evidence : "";
  const b = doc.baseline, f = doc.final;
  const change = b && f ? `${fmt(b.rms_error)} → ${fmt(f.rms_error)} (${fall(b.rms_error, f.rms_error)})` : null;
  $("#an-fall").textContent = change
    ? `Held-out error, LuGre only → with ${f.effects.length ? f.effects.join(", ") : "no effect"}: ${change}` : "";
  $("#an-history tbody").prepend(el("tr", {"data-run": ++runs},
    el("td", {}, String(runs)), el("td", {}, name), el("td", {}, added || "–"), el("td", {}, named.join(", ") || "–"),
    el("td", {class: "fall"}, change || fmt(doc.fit && doc.fit.rms_error)),
    el("td", {}, !left ? "–" : left.structured ? "unexplained" : "nothing")));
  const unc = doc.uncertainty || {}, ok = doc.identifiable || {};
  $("#an-params tbody").replaceChildren(...Object.entries(doc.parameters).map(([k, v]) =>
    el("tr", {"data-param": k}, el("td", {}, k), el("td", {class: "value"}, fmt(v)), el("td", {class: "muted"}, fmt(unc[k])),
       el("td", {}, k in ok ? (ok[k] ? "yes" : "no") : "–"))));
  for (const [k, why] of Object.entries(doc.not_identified || {}))
    $("#an-params tbody").append(el("tr", {"data-param": k}, el("td", {}, k), el("td", {}, "–"), el("td", {}, ""),
                                     el("td", {class: "muted"}, `not identified: ${why}`)));
  const diag = doc.diagnosis || [];
  const row = d => el("tr", {"data-effect": d.effect}, el("td", {}, d.effect),
    el("td", {}, d.significant ? "yes" : d.added ? "added, not credited" : "no"),
    el("td", {}, `${fmt(d.rms_before)} → ${fmt(d.rms_after)}`), el("td", {}, d.evidence));
  $("#an-diag tbody").replaceChildren(...diag.filter(d => d.significant || d.added).map(row));
  const others = diag.filter(d => !d.significant && !d.added);
  $("#an-others").hidden = !others.length;
  $("#an-others tbody").replaceChildren(...others.map(row));
  $("#an-warnings").replaceChildren(...(doc.warnings || []).map(w => el("li", {}, w)));
  // only the PNGs the API drew, as data: URIs (never a URL the key would have to go to)
  const rank = k => { const i = PLOTS.findIndex(([p]) => k === p || (p === "step" && k.startsWith("step"))); return i < 0 ? PLOTS.length : i; };
  const steps = (doc.steps || []).map(s => s.effect);
  $("#an-plots").replaceChildren(...Object.entries(doc.plots || {}).filter(([, src]) => src.startsWith(PNG))
    .sort(([a], [b]) => rank(a) - rank(b) || a.localeCompare(b, undefined, {numeric: true}))
    .map(([k, src]) => {
      const [, title, wide] = PLOTS[rank(k)] || [k, k];
      const n = k.startsWith("step") ? Number(k.slice(4).split("_")[0]) : 0;
      const caption = n ? `step ${n}: + ${steps[n - 1] || ""}` : title;
      return el("figure", {"data-plot": k, class: wide ? "wide" : ""}, el("figcaption", {}, caption), el("img", {src, alt: caption}));
    }));
}

function fall(before, after) {
  if (!(before > 0)) return "–";
  const pct = 100 * (after - before) / before;
  return `${pct > 0 ? "+" : ""}${pct.toFixed(0)} %`;
}
