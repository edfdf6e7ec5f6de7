// Live plot of one joint's position, velocity and torque: three stacked strips on one
// canvas, a shared time axis over the last WINDOW seconds, each strip scaled to its data.
// Plain canvas, no library: the page must work without any network but the bench's own.
import {fmt} from "/static/dom.js";

const WINDOW = 30;          // s of history shown
const MAX_POINTS = 3000;    // per joint: 5 min at the page's 10 Hz sample rate
const SIGNALS = [
  {key: "position", label: "q", color: "#1f77b4"},
  {key: "velocity", label: "v", color: "#2ca02c"},
  {key: "torque", label: "τ", color: "#d62728"},
];

export class LivePlot {
  constructor(canvas) {
    this.canvas = canvas;
    this.series = {};       // joint -> [{t, position, velocity, torque}]
    this.joint = null;
    this.pending = false;
  }

  reset(joints) {
    this.series = {};
    for (const j of joints) this.series[j] = [];
    this.joint = joints[0] || null;
    this.canvas.dataset.points = "0";
    this.draw();
  }

  show(joint) { this.joint = joint; this.draw(); }

  // samples: {joint: {t, position, velocity, torque, state}} from one "sample" event
  add(samples) {
    for (const [j, s] of Object.entries(samples)) {
      const arr = this.series[j] || (this.series[j] = []);
      if (arr.length && s.t <= arr[arr.length - 1].t) continue;      // repeated newest sample
      arr.push(s);
      if (arr.length > MAX_POINTS) arr.splice(0, arr.length - MAX_POINTS);
    }
    if (!this.pending) {
      this.pending = true;
      requestAnimationFrame(() => { this.pending = false; this.draw(); });
    }
  }

  draw() {
    const c = this.canvas, dpr = window.devicePixelRatio || 1;
    const w = c.clientWidth, h = c.clientHeight;
    if (!w || !h) return;
    if (c.width !== Math.round(w * dpr)) { c.width = Math.round(w * dpr); c.height = Math.round(h * dpr); }
    const g = c.getContext("2d");
    g.setTransform(dpr, 0, 0, dpr, 0, 0);
    g.clearRect(0, 0, w, h);
    g.font = "11px sans-serif";
    const data = (this.joint && this.series[this.joint]) || [];
    c.dataset.points = String(data.length);
    const left = 62, right = 8, top = 4, gap = 14, bottom = 18;
    const strip = (h - top - bottom - gap * (SIGNALS.length - 1)) / SIGNALS.length;
    const tEnd = data.length ? data[data.length - 1].t : WINDOW;
    const t0 = Math.max(0, tEnd - WINDOW), t1 = Math.max(tEnd, t0 + 1);
    const visible = data.filter(s => s.t >= t0);
    const x = t => left + (t - t0) / (t1 - t0) * (w - left - right);
    SIGNALS.forEach((sig, i) => {
      const y0 = top + i * (strip + gap);
      g.strokeStyle = "#ccc";
      g.strokeRect(left, y0, w - left - right, strip);
      g.fillStyle = sig.color;
      g.fillText(sig.label, 4, y0 + 12);
      const vals = visible.map(s => s[sig.key]).filter(v => typeof v === "number" && isFinite(v));
      if (!vals.length) return;
      let lo = Math.min(...vals), hi = Math.max(...vals);
      if (hi - lo < 1e-12) { lo -= 1; hi += 1; }
      const pad = 0.08 * (hi - lo);
      lo -= pad; hi += pad;
      const y = v => y0 + strip - (v - lo) / (hi - lo) * strip;
      g.fillStyle = "#555";
      g.fillText(fmt(hi), 4, y0 + 24);
      g.fillText(fmt(lo), 4, y0 + strip - 2);
      if (lo < 0 && hi > 0) {
        g.strokeStyle = "#eee";
        g.beginPath(); g.moveTo(left, y(0)); g.lineTo(w - right, y(0)); g.stroke();
      }
      g.strokeStyle = sig.color;
      g.lineWidth = 1.5;
      g.beginPath();
      let first = true;
      for (const s of visible) {
        const v = s[sig.key];
        if (typeof v !== "number" || !isFinite(v)) continue;
        if (first) { g.moveTo(x(s.t), y(v)); first = false; } else g.lineTo(x(s.t), y(v));
      }
      g.stroke();
      g.lineWidth = 1;
    });
    g.fillStyle = "#555";
    g.fillText(`t = ${t0.toFixed(1)} s`, left, h - 4);
    const end = `${t1.toFixed(1)} s`;
    g.fillText(end, w - right - g.measureText(end).width, h - 4);
  }
}
