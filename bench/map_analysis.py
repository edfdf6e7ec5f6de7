"""``bench analyze`` of a friction-velocity map: the fit, the diagnosis and the report
(``bench.map_fit`` holds the statistics).  The report keeps the time record's keys where they
mean the same (parameters, uncertainty, identifiable, baseline, final, diagnosis, unexplained,
warnings, input, units); ``record`` is "friction_map"."""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from bench import map_fit as mf
from bench.errors import InputError
from bench.friction_map import FrictionMap
from bench.diagnosis import MIN_EFFECT
from bench.unexplained import MIN_SIZE, decays, rising_map

EVIDENCE = {
    "torque_offset": lambda val, u: f"a constant bias of {val['offset']:+.4g} {u} in both directions",
    "direction_asymmetry": lambda val, u: (f"friction levels depend on the direction: Coulomb level "
                                           f"{val['Fc'] * (1 + val['asym']):.4g} {u} for positive and "
                                           f"{val['Fc'] * (1 - val['asym']):.4g} {u} for negative velocity"),
    "stribeck_shape": lambda val, u: (f"the Stribeck dip is {'sharper' if val['delta'] > 1 else 'more gradual'} "
                                      f"than exp(-alpha|v|): exponent delta ~ {val['delta']:.2f}"),
}


class MapAnalysis:
    def __init__(self, m: FrictionMap, add: list[str] | None, diagnose: bool, name: str):
        self.m, self.name = m, name
        v, F = m.v, m.F
        self.warnings = list(m.reading.get("warnings", []))
        # the effects are judged on maps with a dip; whether the dip rises from rest (or is
        # not there at all) is judged on the final model, once an offset or an asymmetry that
        # bent the plain map is in (j4's map with an offset had gone flat, tuning seed 20030)
        dipped = mf.fit(v, F)
        self.baseline, _ = mf.rising(v, F, dipped)
        self.baseline_cv = _rms(F - mf.cv_prediction(v, F, self.baseline))
        self.steps: list[dict] = []
        cur = dipped
        cur_cv = self.baseline_cv if cur is self.baseline else _rms(F - mf.cv_prediction(v, F, cur))
        if add:
            from bench.effects import get
            for e in add:
                get(e)      # an unknown name is told as such
                why = mf.applies(e, m, cur)
                if why:
                    raise InputError(f"{name}: effect {e} cannot be read off this map: {why}")
            for e in add:     # forced, one step each, as on a record in time
                cur, cur_cv = self._step(cur, cur_cv, e)
        elif diagnose:
            while True:
                trials = [self._trial(cur, cur_cv, e) for e in mf.CONTENDERS
                          if e not in cur.model.effects and not mf.applies(e, m, cur)]
                credited = sorted((t for t in trials if t["credit"]), key=lambda t: t["gain"], reverse=True)
                if not credited:
                    break
                best = credited[0]
                close = [t["effect"] for t in credited[1:] if t["gain"] >= mf.CLOSE * best["gain"]]
                self.steps.append(self._entry(best, close))
                cur, cur_cv = best["fit"], best["cv"]
        self.final, self.rise_p = mf.rising(v, F, cur)
        self.final_cv = cur_cv if self.final is cur else _rms(F - mf.cv_prediction(v, F, self.final))
        if not self.steps:
            self.final, self.final_cv = self.baseline, self.baseline_cv
        self.left = mf.lack_of_fit(v, self.final.resid, self.final.p)
        self.spread = mf.speed_spread(v, F, self.final)
        self.across = mf.across_speeds(v, F, self.final)
        scale = abs(self.final.values["Fc"]) or 1.0
        self.shape_wrong = self.across["p_value"] < mf.P_LEFT and self.across["miss_rms"] >= MIN_SIZE * scale
        if self.shape_wrong and "stribeck_shape" in self.final.model.effects:
            self._uncredit_shape(v, F)
        if not mf.both_directions(v):
            self.warnings.append("the map holds one direction only: an offset or a direction asymmetry cannot be "
                                 "told from the friction levels; record both directions")

    def _uncredit_shape(self, v, F) -> None:
        """A Stribeck exponent reshapes the whole map, so beside a shape that fails across the
        speeds it only absorbs part of it: not credited (as on a record in time,
        ``bench.effects.stribeck_shape.whole_only``; |v|^0.5 viscous friction, tuning seed 20013)."""
        for step in self.steps:
            if step["effect"] == "stribeck_shape" and step["significant"]:
                step["significant"] = False
                step["evidence"] += ("; not credited: a Stribeck exponent reshapes the whole friction-velocity map, "
                                     "so it is credited only as the whole story, and the map's shape fails across its speeds")
        rest = tuple(e for e in self.final.model.effects if e != "stribeck_shape")
        self.final = mf.fit(v, F, rest, start=self.final.values, flat=self.final.model.flat)
        self.final_cv = _rms(F - mf.cv_prediction(v, F, self.final))
        self.left = mf.lack_of_fit(v, self.final.resid, self.final.p)
        self.spread = mf.speed_spread(v, F, self.final)

    def _trial(self, cur: mf.Fit, cur_cv: float, effect: str) -> dict:
        v, F = self.m.v, self.m.F
        big = mf.fit(v, F, cur.model.effects + (effect,), start=dict(cur.values), flat=cur.model.flat)
        cv = _rms(F - mf.cv_prediction(v, F, big))
        p = mf.f_test(cur, big)
        peak = mf.term_peak(v, big, effect)
        scale = abs(big.values["Fc"]) or 1.0
        credit = (p < mf.P_CREDIT and cv < (1 - mf.MIN_CV_DROP) * cur_cv and peak >= MIN_EFFECT * scale
                  and (effect != "stribeck_shape" or decays(big.values)))
        return {"effect": effect, "fit": big, "cv": cv, "p": p, "peak": peak, "before": cur_cv,
                "gain": cur.ssr - big.ssr, "credit": credit}

    def _step(self, cur, cur_cv, effect):
        t = self._trial(cur, cur_cv, effect)
        self.steps.append({**self._entry(t, []), "added": True})     # asked for, as a record's report says
        return t["fit"], t["cv"]

    def _entry(self, t: dict, close: list) -> dict:
        u = self.m.units[1]
        explained = 1.0 - (t["cv"] / t["before"]) ** 2 if t["before"] > 0 else 0.0
        text = (f"{EVIDENCE[t['effect']](t['fit'].values, u)}; explains {100 * max(explained, 0):.0f} % of the "
                f"cross-validated residual variance (F test p = {t['p']:.2g})")
        if close:
            text += (f"; a close call: {', '.join(close)} fits nearly as well (on a map an offset and a direction "
                     f"asymmetry differ only by how the dip scales: check the runner-up too)")
        return {"effect": t["effect"], "significant": bool(t["credit"]), "added": False, "rms_before": t["before"],
                "rms_after": t["cv"], "p_value": t["p"], "evidence": text,
                "values": {mf.VALUE_OF[t["effect"]]: t["fit"].values[mf.VALUE_OF[t["effect"]]]}}

    # --- the report ----------------------------------------------------------------------
    def report(self) -> dict:
        m, base, final = self.m, self.baseline, self.final
        noise_se = final.stderr()
        values = {k: final.values[k] for k in ("Fc", "Fs", "alpha", "sigma2")}
        se = dict(noise_se, **{k: float(np.hypot(noise_se[k], d)) for k, d in self.spread.items()})
        u_v, u_t = m.units
        scale = abs(values["Fc"]) or 1.0
        significant = self.left["p_value"] < mf.P_LEFT
        bent = None
        if self.rise_p is not None:     # the rise fits significantly better than no dip at all
            bent = (rising_map(values, noise_se, degenerate=True)
                    or f"the fitted friction rises from rest (Fs = {values['Fs'] / values['Fc']:.2f} Fc), which LuGre's "
                       f"Stribeck decay cannot describe: LuGre was bent to absorb a velocity dependence of another shape, "
                       f"and its Fc and sigma2 are biased")
            bent += f" (F test against a map without a dip: p = {self.rise_p:.2g})"
        structured = bool(bent) or self.shape_wrong or (significant and self.left["systematic_rms"] >= MIN_SIZE * scale)
        effects = [s["effect"] for s in self.steps if s["significant"]]
        warnings = self.warnings + [f"sigma0 and sigma1 are not identified: {mf.NOT_FROM_A_MAP}"]
        known = mf.identifiable(values, se)
        moved = [k for k, d in self.spread.items() if d > noise_se[k] and d > 0.01 * abs(values[k])]
        if moved:
            warnings.append("fitted on the slower and on the faster speeds, the values move by "
                            + ", ".join(f"{k} {100 * self.spread[k] / abs(values[k]):.1f} %" for k in moved)
                            + ": counted in the uncertainty")
        if final.model.flat:
            warnings.append("the map shows no Stribeck dip (Fs = Fc fits as well): Fs and alpha are not identifiable; "
                            "read Fc as the friction level")
        speeds = np.abs(m.v)
        if values["alpha"] * speeds.min() > mf.DIP_BELOW and not final.model.flat:
            known.update(Fs=False, alpha=False)
            warnings.append(f"the map's slowest speed, {speeds.min():.3g} {u_v}, lies {values['alpha'] * speeds.min():.1f}/alpha "
                            f"into the Stribeck dip: Fs is extrapolated to rest along the dip's assumed shape, not read "
                            f"off the map; record slower speeds")
        if values["alpha"] * speeds.max() < mf.DIP_BELOW and not final.model.flat:
            known.update(Fc=False, alpha=False)
            warnings.append(f"the Stribeck dip has not settled at the map's fastest speed, {speeds.max():.3g} {u_v}: Fc is "
                            f"extrapolated beyond every point; record faster speeds")
        for k in ("Fc", "Fs", "alpha", "sigma2"):
            if not known[k]:
                warnings.append(f"{k} is not identifiable from this map (standard error "
                                f"{se.get(k, float('nan')):.3g} against {values[k]:.4g})")
        return _strict({
            "record": "friction_map",
            "parameters": values,
            "uncertainty": {k: se[k] for k in values},
            "identifiable": known,
            "speed_spread": self.spread,
            "not_identified": {"sigma0": mf.NOT_FROM_A_MAP, "sigma1": mf.NOT_FROM_A_MAP},
            "section3_estimates": _eq8(m.v, m.F),
            "fit": {"rms_error": _rms(final.resid), "nrmse": _rms(final.resid) / (np.ptp(m.F) or 1.0),
                    "fit_percent": 100.0 * (1.0 - _rms(final.resid) / (np.std(m.F) or 1.0)),
                    "points": final.n},
            "baseline": {"parameters": {k: base.values[k] for k in values}, "rms_error": self.baseline_cv,
                         "start": "map_fit", "scored": "cross-validated over interleaved speeds"},
            "final": {"effects": effects, "rms_error": self.final_cv,
                      "values": {mf.VALUE_OF[e]: final.values[mf.VALUE_OF[e]] for e in effects}},
            "diagnosis": self.steps,
            "unexplained": {"structured": structured, "evidence": bent or self._left_text(structured, scale),
                            "test": self.left, "across_speeds": self.across},
            "warnings": warnings,
            "input": {"format": m.reading.get("format"), "record": "friction_map",
                      "columns": m.reading.get("columns"), "points": final.n,
                      "rows_at_rest": m.reading.get("rows_at_rest", 0), "rows_lost": m.reading.get("rows_lost", 0),
                      "directions": int(np.any(m.v > 0)) + int(np.any(m.v < 0)),
                      "speed_range": [float(np.abs(m.v).min()), float(np.abs(m.v).max())],
                      "units": {"velocity": u_v, "torque": u_t}},
            "units": {"conversions": m.reading.get("units", {})},
        })

    def _left_text(self, structured: bool, scale: float) -> str:
        left, u = self.left, self.m.units[1]
        size = f"{left['systematic_rms']:.3g} {u} ({100 * left['systematic_rms'] / scale:.1f} % of Fc)"
        test = f"{left['method']}, p = {left['p_value']:.2g}"
        if self.shape_wrong:
            a = self.across
            fitted = "slower" if a["held_out"] == "fastest" else "faster"
            return (f"the map's shape fails across its speeds: fitted on the {fitted} two thirds, the model misses the "
                    f"{a['held_out']} third by {a['miss_rms']:.3g} {u} ({100 * a['miss_rms'] / scale:.1f} % of Fc) beyond "
                    f"its own uncertainty (chi-square p = {a['p_value']:.2g}) -- physics of the speed outside the library "
                    f"(a viscous term not linear in the speed, a second Stribeck regime); its Fc and sigma2 are biased")
        if structured:
            r, v = self.final.resid, self.m.v
            worst = v[np.argmax(np.abs(r))]
            return (f"the map keeps a structure no library effect explains: {size} systematic ({test}); the model "
                    f"misses most at {worst:.4g} {self.m.units[0]} -- physics of the speed outside the library "
                    f"(a viscous term not linear in the speed, a second Stribeck regime)")
        return f"nothing left to explain: what the model leaves is {size} systematic ({test})"

    def write_residuals(self, path: Path) -> None:
        """velocity, measured, baseline, final, held_out (every point is scored in one fold)."""
        v, F = self.m.v, self.m.F
        table = np.column_stack([v, F, mf.friction(v, self.baseline.values), mf.friction(v, self.final.values),
                                 np.ones_like(v)])
        np.savetxt(path, table, delimiter=",", header="velocity,measured,baseline,final,held_out",
                   comments="", fmt="%.9g")

    def write_plots(self, directory: Path) -> list[Path]:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        directory.mkdir(parents=True, exist_ok=True)
        v, F = self.m.v, self.m.F
        grid = np.concatenate([-np.geomspace(np.abs(v).max(), np.abs(v).min(), 200), [np.nan],
                               np.geomspace(np.abs(v).min(), np.abs(v).max(), 200)])
        grid = grid[~((grid < v.min()) | (grid > v.max()))]      # no line through rest (NaN kept)
        fig, (a, b) = plt.subplots(2, 1, figsize=(8, 7), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
        a.plot(v, F, "k.", label="measured")
        a.plot(grid, mf.friction(grid, self.baseline.values), "-", label="LuGre steady state")
        if self.final is not self.baseline:
            a.plot(grid, mf.friction(grid, self.final.values), "--", label="with " + ", ".join(self.final.model.effects))
        a.set_ylabel(f"friction [{self.m.units[1]}]")
        a.legend()
        b.plot(v, self.final.resid, "k.")
        b.axhline(0.0, color="grey", lw=0.5)
        # speeds spanning decades: the dip near rest and the viscous line both in view
        b.set_xscale("symlog", linthresh=float(np.abs(v).min()))
        b.set_xlabel(f"velocity [{self.m.units[0]}] (logarithmic beyond the slowest speed)")
        b.set_ylabel("residual")
        out = directory / "friction_map.png"
        fig.savefig(out, dpi=100)
        plt.close(fig)
        return [out]

    def write_html(self, path: Path) -> None:
        from bench.report_html import _img
        doc = self.report()
        plots = self.write_plots(path.parent / (path.stem + "_plots"))
        def num(x, f):          # a value no fit gives is None in the report
            return "–" if x is None else format(x, f)
        rows = "".join(f"<tr><td>{k}</td><td>{num(val, '.6g')}</td><td>{num(doc['uncertainty'].get(k), '.3g')}</td></tr>"
                       for k, val in doc["parameters"].items())
        items = "".join(f"<li>{html.escape(d['effect'])}: {html.escape(d['evidence'])}</li>" for d in doc["diagnosis"])
        path.write_text(
            f"<!doctype html><meta charset=utf-8><title>{html.escape(self.name)}</title>"
            f"<h1>Friction-velocity map: {html.escape(self.name)}</h1>"
            f"<table><tr><th>parameter</th><th>value</th><th>std. error</th></tr>{rows}</table>"
            f"<ul>{items}</ul><p>{html.escape(doc['unexplained']['evidence'])}</p>"
            + "".join(f"<p>{html.escape(w)}</p>" for w in doc["warnings"])
            + "".join(_img(p) for p in plots))      # inlined, as a record's report: one file travels


def analyze_map(m: FrictionMap, add: list[str] | None = None, diagnose_effects: bool = True,
                name: str = "map") -> MapAnalysis:
    return MapAnalysis(m, add, diagnose_effects, name)


def _strict(doc):
    """Strict JSON: a value no fit could give (alpha's error on a map without a dip, a test
    on too few points) is None, as the record's report writes it (``identify._finite_or_none``)."""
    if isinstance(doc, dict):
        return {k: _strict(x) for k, x in doc.items()}
    if isinstance(doc, (list, tuple)):
        return [_strict(x) for x in doc]
    if isinstance(doc, (float, np.floating)):
        return float(doc) if np.isfinite(doc) else None
    if isinstance(doc, np.integer):
        return int(doc)
    return doc


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else 0.0


def _eq8(v, F) -> dict:
    """Section III on a map: Fc and sigma2 from the line through the faster half of the speeds
    (eq. 8, both directions folded), Fs from the slowest speeds' level."""
    speed, level = np.abs(v), np.sign(v) * F
    fast = speed >= np.median(speed)
    (slope, icpt), *_ = np.linalg.lstsq(np.column_stack([speed[fast], np.ones(int(fast.sum()))]),
                                        level[fast], rcond=None)   # one speed there: no slope, no warning
    slow = speed <= np.quantile(speed, 0.1)
    return {"Fc": float(icpt), "sigma2": float(slope), "Fs": float(np.mean(level[slow]))}
