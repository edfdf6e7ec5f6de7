// The bench view: every joint's state, transport, limits, drive, model and compensation
// switch (operators may flip it), refreshed every POLL.joints_ms while shown.
import * as api from "/static/api.js";
import {$, el, fmt} from "/static/dom.js";

let timer = null;
let gen = 0;            // the newest refresh; an older one still in flight neither renders nor reschedules
const errors = {};     // joint -> the API's answer to the last switch that failed

export function enter(ctx) { refresh(ctx); }
export function leave() { clearTimeout(timer); timer = null; gen++; }

async function refresh(ctx) {
  clearTimeout(timer);
  const mine = ++gen;
  try {
    const joints = await Promise.all(ctx.joints.map(j => api.get(`/joints/${encodeURIComponent(j)}`)));
    if (mine !== gen) return;
    render(ctx, joints);
    $("#joints-msg").textContent = "";
  } catch (e) {
    if (mine !== gen) return;
    $("#joints-msg").textContent = e.message;
  }
  if (ctx.view === "bench") timer = setTimeout(() => refresh(ctx), api.POLL.joints_ms);
}

function render(ctx, joints) {
  const body = $("#joints tbody");
  const operator = ctx.role === "operator" || ctx.role === "admin";
  body.replaceChildren(...joints.map(j => {
    const lim = j.limits;
    const d = j.drive || {};
    const m = j.model;
    const comp = j.compensation;
    const state = el("td", {class: j.state === "estopped" ? "error" : ""}, j.state,
      j.run_id ? el("div", {}, el("a", {href: "#", onclick: ev => { ev.preventDefault(); ctx.go("live", j.run_id); }},
                                     j.run_id)) : null);
    const model = m
      ? el("td", {}, el("div", {class: "muted"}, m.id),
          ["Fc", "Fs", "alpha", "sigma0", "sigma1", "sigma2"].map(k => `${k} ${fmt(m.parameters[k])}`).join(" · "))
      : el("td", {class: "muted"}, "no model yet");
    const label = comp.enabled ? "on" : "off";
    const compCell = operator
      ? el("td", {}, el("label", {}, el("input", {type: "checkbox", class: "comp-switch", "data-joint": j.id,
          checked: comp.enabled, disabled: !m, onchange: ev => toggle(ctx, j.id, ev.target)}), " ", label),
          el("span", {class: "error comp-msg"}, errors[j.id] || ""))
      : el("td", {}, label);
    return el("tr", {"data-joint": j.id},
      el("td", {}, el("b", {}, j.id), el("div", {class: "muted"}, j.joint_type)),
      state,
      el("td", {}, j.transport),
      el("td", {}, `[${lim.position.map(fmt).join(", ")}] / ${fmt(lim.velocity)} / ${fmt(lim.torque)}`),
      el("td", {}, d.state || "–", d.open ? ` · q ${fmt(d.position)} · τ ${fmt(d.torque)}` : ""),
      model, compCell);
  }));
}

async function toggle(ctx, joint, box) {
  try {
    await api.put(`/joints/${encodeURIComponent(joint)}/compensation`, {enabled: box.checked});
    delete errors[joint];
  } catch (e) {
    errors[joint] = e.message;
  }
  refresh(ctx);
}
