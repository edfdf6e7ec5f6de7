"""HTML reports of a run, self-contained (plots embedded), and the trace of a run as CSV.

identify     the analysis report written by ``bench.analysis`` (``report-<joint>.html``);
             without plots, a summary page from the run's result
tracking     the metrics per variant and the tracking plot (Fig. 6/9 style)
calibrate    per joint: status, parameters, tracking errors, friction map and tracking plots
"""
from __future__ import annotations

import base64
import html
import time
from pathlib import Path

from bench.store import Store
from bench.traces import read_trace, trace_to_record
from procedures.config import BenchConfig, declared_inertia

from api.runs import Conflict, NotFound

_STYLE = ("<style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}"
          "td,th{border:1px solid #ccc;padding:3px 8px;vertical-align:top}</style>")


def _img(path) -> str:
    p = Path(path) if path else None
    if p is None or not p.is_file():
        return ""
    return f'<img src="data:image/png;base64,{base64.b64encode(p.read_bytes()).decode()}" style="max-width:100%">'


def _num(x) -> str:
    return f"{x:.4g}" if isinstance(x, (int, float)) else html.escape(str(x if x is not None else "-"))


def _page(title: str, body: str) -> str:
    e = html.escape
    return f"<!doctype html><html><head><meta charset='utf-8'><title>{e(title)}</title>{_STYLE}</head><body>{body}</body></html>"


def run_report(store: Store, run: dict, procedure: str, joint: str | None) -> str:
    if run["state"] in ("queued", "running"):
        raise Conflict(f"run {run['id']} is still {run['state']}; its report comes when it ends")
    result = run.get("result") or {}
    joints = result.get("joints") or {}
    e = html.escape
    head = (f"<h1>{e(procedure)} run {e(run['id'])}</h1><p>state <b>{e(run['state'])}</b>"
            + (f" &mdash; {e(run['error'])}" if run.get("error") else "") + "</p>")
    d = store.run_dir(run["id"])
    if procedure == "identify":
        jid = joint or next(iter(joints), None)
        if joint is not None and joint not in joints:
            raise NotFound(f"run {run['id']} identified no joint {joint!r}")
        page = d / f"report-{jid}.html"
        if jid is not None and page.is_file():
            return page.read_text()
        rows = "".join(f"<tr><td>{e(j)}</td><td>{e(str(r.get('model_id')))}</td><td>"
                       + ", ".join(f"{k}={v:.4g}" for k, v in (r.get("parameters") or {}).items())
                       + "</td></tr>" for j, r in joints.items())
        return _page(f"identify {run['id']}", head + "<table><tr><th>joint</th><th>model</th>"
                     f"<th>parameters</th></tr>{rows}</table>")
    if procedure == "tracking":
        parts = [head]
        for j, r in joints.items():
            rows = "".join(f"<tr><td>{e(v)}</td><td>{_num(m.get('rms_error'))}</td><td>{_num(m.get('max_error'))}</td>"
                           f"<td>{_num(m.get('torque_rate_rms'))}</td></tr>" for v, m in (r.get("variants") or {}).items())
            parts.append(f"<h2>{e(j)}: compensation {e(str(r.get('compensation')))}, model {e(str(r.get('model_id')))}</h2>"
                         "<table><tr><th>variant</th><th>RMS error</th><th>max error</th><th>RMS dτ/dt</th></tr>"
                         f"{rows}</table>" + _img(d / f"tracking-{j}.png"))
        return _page(f"tracking {run['id']}", "".join(parts))
    # calibration: the procedure's own report.json has the plot paths
    report = result.get("report") or {}
    parts = [head]
    for j, r in (report.get("joints") or {}).items():
        st = r.get("stages", {})
        ident = (st.get("identify") or {}).get("result") or {}
        val = (st.get("validate") or {}).get("result") or {}
        params = ", ".join(f"{k}={v:.4g}" for k, v in (ident.get("parameters") or {}).items())
        rms = (f"{_num(val['none']['rms_error'])} &rarr; {_num(val['identified']['rms_error'])}"
               if "none" in val and "identified" in val else "-")
        parts.append(f"<h2>{e(j)}: {e(str(r.get('status')))}</h2><p>{e(r.get('reason') or '')}</p>"
                     f"<p>parameters: {e(params) or '-'}</p><p>tracking RMS error off &rarr; on: {rms}</p>"
                     + _img(ident.get("map_plot")) + _img(val.get("plot")))
    return _page(f"calibration {run['id']}", "".join(parts))


def trace_csv(store: Store, cfg: BenchConfig, run: dict, joint: str, every: int) -> str:
    """One joint's columns of the run's trace in the record format (``bench analyze`` reads
    it).  A calibration has no trace of its own: its newest child run of that joint does."""
    d = store.run_dir(run["id"])
    if not _has_trace(d):
        for child in store.list_runs(parent_id=run["id"], joint_id=joint):
            if _has_trace(store.run_dir(child["id"])):
                d = store.run_dir(child["id"])
                break
        else:
            raise NotFound(f"run {run['id']} has no trace" + (f" for joint {joint!r}" if joint else ""))
    for attempt in range(3):   # a trace being compacted at the end of a run: read again
        try:
            table = read_trace(d)
            break
        except (OSError, ValueError) as exc:
            if attempt == 2:
                raise Conflict(f"the trace of run {run['id']} is being written; retry") from exc
            time.sleep(0.05)
    if f"q_{joint}" not in table.column_names:
        raise NotFound(f"run {run['id']} has no trace of joint {joint!r}")
    if every > 1:
        table = table.take(list(range(0, table.num_rows, every)))
    meta = {"joint": joint, "run_id": run["id"], "source": "bench trace"}
    try:
        j = cfg.joint(joint)
        meta.update(inertia=declared_inertia(j, {}), joint_type=j.get("joint_type", "revolute"))
    except Exception:
        pass
    return trace_to_record(table, joint, meta).to_csv()


def _has_trace(d: Path) -> bool:
    return (d / "trace.parquet").exists() or any(d.glob("chunk-*.parquet"))
