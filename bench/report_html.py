"""The self-contained HTML report of ``bench analyze --html``: the report's tables and its
PNG plots inlined, so one file travels."""
from __future__ import annotations

import base64
import html
from pathlib import Path


def data_uri(path: Path) -> str:
    """A PNG as a data: URI, so a report (or ``POST /analyze?plots=true``'s JSON) carries it."""
    return "data:image/png;base64," + base64.b64encode(Path(path).read_bytes()).decode()


def plots_as_data(analysis) -> dict[str, str]:
    """An analysis's plots (a record's or a map's), drawn in a scratch directory and returned
    as data: URIs keyed by what each shows; nothing is left on disk."""
    import tempfile
    with tempfile.TemporaryDirectory(prefix="bench-plots-") as tmp:
        files = analysis.write_plots(Path(tmp))
        if not isinstance(files, dict):            # a map's: a list of files
            files = {Path(f).stem: f for f in files}
        return {k: data_uri(f) for k, f in files.items()}


def _img(path: Path) -> str:
    return f'<img src="{data_uri(path)}" style="max-width:100%">'


def render_html(name: str, doc: dict, files: dict) -> str:
    e = html.escape
    def se(k):
        x = doc["uncertainty"].get(k)
        return "" if x is None else f"{x:.3g}"

    rows = "".join(
        f"<tr><td>{e(k)}</td><td>{v:.6g}</td><td>{se(k)}</td>"
        f"<td>{'yes' if doc['identifiable'].get(k) else '<b>no</b>'}</td></tr>"
        for k, v in doc["parameters"].items())
    diag_rows = "".join(
        f"<tr><td>{'&#10003;' if d['significant'] else ''}</td><td>{e(d['effect'])}</td>"
        f"<td>{d['rms_before']:.4g}</td><td>{d['rms_after']:.4g}</td><td>{e(d['evidence'])}</td></tr>"
        for d in doc.get("diagnosis", []))
    steps = "".join(f"<h3>{e(k)}</h3>{_img(p)}" for k, p in files.items() if k.startswith("step"))
    parts = [
        f"<html><head><meta charset='utf-8'><title>friction analysis: {e(name)}</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:3px 8px}</style></head><body>",
        f"<h1>Friction analysis: {e(name)}</h1>",
        f"<p>inertia {doc['inertia']:.6g}; fit {doc['fit'].get('fit_percent', 0):.2f} %, "
        f"rms error {doc['fit']['rms_error']:.4g}</p>",
        "<h2>Identified LuGre model</h2><table><tr><th>parameter</th><th>value</th><th>std. error</th>"
        f"<th>identifiable</th></tr>{rows}</table>",
    ]
    if "baseline" in doc:
        parts.append(f"<h2>Held-out error</h2><p>LuGre only: {doc['baseline']['rms_error']:.4g} &rarr; "
                     f"with {e(', '.join(doc['final']['effects']) or 'no effect')}: {doc['final']['rms_error']:.4g}</p>")
        if "error_fall" in files:
            parts.append(_img(files["error_fall"]))
        parts.append("<h2>Diagnosis</h2><table><tr><th>sig.</th><th>effect</th><th>rms before</th>"
                     f"<th>rms after</th><th>evidence</th></tr>{diag_rows}</table>")
        left = doc.get("unexplained")
        if left:
            head = "Still unexplained" if left["structured"] else "Nothing left to explain"
            parts.append(f"<h2>{head}</h2><p>{e(left['evidence'])}</p>")
        parts.append(f"<h2>Steps</h2>{steps}")
        if "residual_baseline" in files:
            parts.append(f"<h2>Where LuGre alone fails</h2>{_img(files['residual_baseline'])}")
    for key, title in (("map", "Friction-velocity map"), ("presliding", "Presliding"),
                       ("inertia", "Inertia sensitivity (Fig. 2)")):
        if key in files:
            parts.append(f"<h2>{title}</h2>{_img(files[key])}")
    for w in doc.get("warnings", []):
        parts.append(f"<p>warning: {e(w)}</p>")
    parts.append("</body></html>")
    return "\n".join(parts)
