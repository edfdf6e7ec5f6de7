// The page's frame: the key and role, the views, and the e-stop on every view.
import * as api from "/static/api.js";
import {$} from "/static/dom.js";
import * as bench from "/static/bench.js";
import * as run from "/static/run.js";
import * as history from "/static/history.js";
import * as analyze from "/static/analyze.js";

const VIEWS = {bench, start: run.start, live: run.live, history: history.runs, compare: history.compare,
               analyze: analyze.view};
const ctx = {role: null, name: null, bench: null, joints: [], estop: null, view: null, go};
let healthTimer = null;
let healthGen = 0;      // one polling loop at a time, also across a log-out and log-in

function show(id) {
  for (const s of document.querySelectorAll("section.view")) s.hidden = s.id !== "view-" + id;
  for (const b of document.querySelectorAll("nav button")) b.classList.toggle("active", b.dataset.view === id);
}

// open a view; views with an `enter` start their own polling and stop it in `leave`
function go(view, arg) {
  if (ctx.view && VIEWS[ctx.view].leave) VIEWS[ctx.view].leave(ctx);
  ctx.view = view;
  show(view);
  if (VIEWS[view].enter) VIEWS[view].enter(ctx, arg);
}

export function notice(text) {
  const n = $("#notice");
  n.textContent = text || "";
  n.hidden = !text;
}

async function login(key, quiet) {
  api.session.key = key;
  try {
    const who = await api.get("/whoami");
    const joints = await api.get("/joints");
    Object.assign(ctx, {role: who.role, name: who.name, bench: joints.bench, joints: joints.joints.map(j => j.id)});
  } catch (e) {
    api.session.key = null;
    return logout(e.status === 401
      ? `That key was not accepted (${e.message}). Check it and try again.`
      : `Cannot log in: ${e.message}`, quiet);
  }
  document.body.dataset.role = ctx.role;
  $("#who").textContent = `${ctx.name} · ${ctx.role}`;
  $("#bench-name").textContent = `bench ${ctx.bench}`;
  $("#nav").hidden = false;
  $("#logout").hidden = false;
  $("#login-msg").textContent = "";
  for (const v of Object.values(VIEWS)) if (v.init) v.init(ctx);
  pollHealth();
  go("bench");
}

function logout(message) {
  api.session.key = null;
  if (ctx.view && VIEWS[ctx.view].leave) VIEWS[ctx.view].leave(ctx);
  ctx.view = null;
  clearTimeout(healthTimer);
  healthGen++;
  document.body.dataset.role = "";
  $("#nav").hidden = true;
  $("#logout").hidden = true;
  $("#who").textContent = "";
  $("#login-msg").textContent = message || "";
  $("#login-key").value = "";
  show("login");
}

// The e-stop state is shown on every view: /health says whether it is latched (every
// POLL.health_ms), /estop by whom and which drives it stopped (once per latch).
async function pollHealth() {
  clearTimeout(healthTimer);
  const mine = ++healthGen;
  try {
    const h = await api.get("/health");
    if (mine !== healthGen) return;
    if (h.estop && !(ctx.estop && ctx.estop.active)) showEstop(await api.get("/estop"));
    else if (!h.estop && (!ctx.estop || ctx.estop.active)) showEstop({active: false});
  } catch (e) {
    if (mine !== healthGen) return;
    if (e.status === 401) return logout("Your key is no longer accepted (revoked?): enter a key.");
    $("#estop-state").textContent = "service unreachable";
    $("#estop-state").className = "pill bad";
  }
  if (api.session.key && mine === healthGen) healthTimer = setTimeout(pollHealth, api.POLL.health_ms);
}

function showEstop(state) {
  ctx.estop = state;
  const pill = $("#estop-state");
  pill.textContent = state.active ? "E-STOP LATCHED" : "e-stop: clear";
  pill.className = state.active ? "pill bad" : "pill good";
  $("#estop-banner").hidden = !state.active;
  if (state.active) {
    $("#estop-reason").textContent = state.reason || "";
    const drives = state.drives || [];
    $("#estop-drives").textContent = drives.length
      ? "; " + drives.map(d => `${d.joint}: ${d.torque_off ? "torque off" : d.torque_off === false ? "TORQUE NOT CONFIRMED OFF" : "unknown"}`).join(", ")
      : "";
  }
  $("#estop-msg").textContent = "";
  document.dispatchEvent(new CustomEvent("estop", {detail: state}));
}

async function estop() {
  if (!api.session.key) {
    $("#login-msg").textContent = "Enter a key first: the e-stop needs any valid key.";
    return;
  }
  try {
    showEstop(await api.post("/estop"));
  } catch (e) {
    notice(`E-STOP FAILED: ${e.message}`);
  }
}

async function resetEstop() {
  try {
    showEstop(await api.post("/estop/reset"));
  } catch (e) {
    $("#estop-msg").textContent = e.message;
  }
}

document.addEventListener("DOMContentLoaded", () => {
  $("#estop").addEventListener("click", estop);
  $("#estop-reset").addEventListener("click", resetEstop);
  $("#logout").addEventListener("click", () => logout());
  $("#login-form").addEventListener("submit", ev => {
    ev.preventDefault();
    const key = $("#login-key").value.trim();
    if (!key) { $("#login-msg").textContent = "Enter a key."; return; }
    login(key);
  });
  for (const b of document.querySelectorAll("nav button")) b.addEventListener("click", () => go(b.dataset.view));
  if (api.session.key) login(api.session.key, true); else show("login");
});
