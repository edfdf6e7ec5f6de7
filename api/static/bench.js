// The bench view: every joint's state, transport, limits, drive, model and compensation
// switch (operators may flip it), refreshed every POLL.joints_ms while shown.  Rows are
// updated in place: the switch under a technician's finger is never replaced by a refresh.
import * as api from "/static/api.js";
import {$, el, fmt} from "/static/dom.js";

let timer = null;
let gen = 0;            // the newest refresh; an older one still in flight neither renders nor reschedules
const rows = {};        // joint -> {tr, cells, box, label, msg}
const pending = new Set();   // joints whose switch is being sent
const errors = {};      // joint -> the API's answer to the last switch that failed

// at each log-in: the rows are built anew for this key's role
export function init() {
  for (const id of Object.keys(rows)) delete rows[id];
  $("#joints tbody").replaceChildren();
}
export function enter(ctx) { refresh(ctx); }
export function leave() { clearTimeout(timer); timer = null; gen++; }

async function refresh(ctx) {
  clearTimeout(timer);
  const mine = ++gen;
  try {
    const joints = await Promise.all(ctx.joints.map(j => api.get(`/joints/${encodeURIComponent(j)}`)));
    if (mine !== gen) return;
    for (const j of joints) update(ctx, j);
    $("#joints-msg").textContent = "";
  } catch (e) {
    if (mine !== gen) return;
    $("#joints-msg").textContent = e.message;
  }
  if (ctx.view === "bench") timer = setTimeout(() => refresh(ctx), api.POLL.joints_ms);
}

function row(ctx, id) {
  if (rows[id]) return rows[id];
  const cells = Array.from({length: 7}, () => el("td"));
  const r = {tr: el("tr", {"data-joint": id}, cells), cells};
  if (ctx.role === "operator" || ctx.role === "admin") {
    r.box = el("input", {type: "checkbox", class: "comp-switch", "data-joint": id});
    r.box.addEventListener("change", () => toggle(ctx, id, r.box));
    r.label = el("span");
    r.msg = el("span", {class: "error comp-msg"});
    cells[6].append(el("label", {}, r.box, " ", r.label), " ", r.msg);
  }
  $("#joints tbody").append(r.tr);
  return rows[id] = r;
}

function update(ctx, j) {
  const r = row(ctx, j.id);
  const [name, state, transport, limits, drive, model, comp] = r.cells;
  const lim = j.limits, d = j.drive || {}, m = j.model;
  name.replaceChildren(el("b", {}, j.id), el("div", {class: "muted"}, j.joint_type));
  state.className = j.state === "estopped" ? "error" : "";
  state.replaceChildren(j.state, j.run_id ? el("div", {}, el("a", {href: "#", onclick: ev => {
    ev.preventDefault(); ctx.go("live", j.run_id); }}, j.run_id)) : "");
  transport.textContent = j.transport;
  limits.textContent = `[${lim.position.map(fmt).join(", ")}] / ${fmt(lim.velocity)} / ${fmt(lim.torque)}`;
  drive.textContent = (d.state || "–") + (d.open ? ` · q ${fmt(d.position)} · τ ${fmt(d.torque)}` : "");
  model.className = m ? "" : "muted";
  model.replaceChildren(...(m ? [el("div", {class: "muted"}, m.id),
    ["Fc", "Fs", "alpha", "sigma0", "sigma1", "sigma2"].map(k => `${k} ${fmt(m.parameters[k])}`).join(" · ")]
    : ["no model yet"]));
  const on = j.compensation.enabled;
  if (!r.box) { comp.textContent = on ? "on" : "off"; return; }
  if (!pending.has(j.id)) r.box.checked = on;
  r.box.disabled = !m;
  r.label.textContent = on ? "on" : "off";
  r.msg.textContent = errors[j.id] || "";
}

async function toggle(ctx, joint, box) {
  pending.add(joint);
  try {
    await api.put(`/joints/${encodeURIComponent(joint)}/compensation`, {enabled: box.checked});
    delete errors[joint];
  } catch (e) {
    errors[joint] = e.message;
  } finally {
    pending.delete(joint);
  }
  refresh(ctx);
}
