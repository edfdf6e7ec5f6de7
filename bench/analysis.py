"""``bench analyze``: identify, compare, find where the model fails, name the missing effect,
add it and show the error fall.  ``analyze_record`` returns an ``Analysis`` that renders the
JSON contract, the PNG plots and a self-contained HTML report."""
from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from bench import inertia_estimate, plots
from bench.checkpoint import checkpoint
from bench.clock_room import ClockRoom, placed_in_room
from bench.coarse_time import spread
from bench.diagnosis import ARTIFACT_RATIO, MIN_EXPLAINED_SIZE, Diagnosis, diagnose
from bench.pruning import drop_absorbers
from bench.effects.gear import friction_beyond_gear, friction_beyond_on
from bench.errors import BenchError, InputError, NotIdentifiable
from bench.fitting import LUGRE_KEYS
from bench.identify import Identification, identify, judged
from bench.perfect_model import replay, torque_step
from bench.measured_start import measured_start
from bench.reading_warnings import reading_warnings, with_hint
from bench.report_input import reading_section
from bench.report_html import render_html
from bench.predictability import assess_predictability
from bench.records import Record
from bench.resample import on_grid
from bench.residuals import breakdown
from bench.slow_stream import filled_forward
from bench import chain_bias, load_torque, structure_spread, undetermined_fit
from bench.unexplained import assess, level_changes, noise_floor, rest_grows, state_structured, structured
from bench.validate import in_range, record_magnitudes
from bench.gear_story import beyond_wins, gear_hysteresis_left, left_structured, mimic_without_gear, \
    inertia_like_spring, position_series_credited
from bench.wide_band import gear_settled, wider_band, widened_warning


@dataclass
class Analysis:
    record: Record
    ident: Identification
    diagnosis: Diagnosis | None
    name: str = "record"
    plot_files: dict = field(default_factory=dict)
    clock_room: ClockRoom = field(default_factory=ClockRoom)    # bench.clock_room: a merged clock
    _spread: tuple | None = field(default=None, repr=False)      # bench.structure_spread, once
    _chain: dict | None = field(default=None, repr=False)        # bench.chain_bias, once

    # --- the JSON contract -------------------------------------------------------------------
    def report(self) -> dict:
        doc = self.ident.report()
        doc.update(self.reading())
        if self.diagnosis is None:
            self.clock_room.told(doc)
            chain_bias.widened(doc, self.chain_shift())
            data = self.ident.data       # a fit run off is said without the diagnosis too
            undetermined_fit.told(doc, data.friction, 1.0 / data.c.dt, data.c.cutoff)
            return doc
        d = self.diagnosis
        if d.started_from:     # not the identification's: a wider band's diagnosis may replace this one
            doc["warnings"] = doc.get("warnings", []) + [d.started_from]
        final = d.model.result
        lugre = {k: float(d.model.values[k]) for k in LUGRE_KEYS}
        doc["baseline"] = {"rms_error": d.baseline_rms, "parameters": doc["parameters"],
                           "fit": dict(doc["fit"]), "start": "lugre_fit"}
        if d.started_from:     # the error above is of the values the diagnosis started from
            doc["baseline"].update(start="section_iii", lugre_fit_parameters=doc["parameters"],
                                   parameters={k: float(d.start.values[k]) for k in LUGRE_KEYS})
        if d.model.effects:  # the model with effects is the better estimate of LuGre too
            doc["parameters"] = lugre
            doc["uncertainty"] = {k: final.stderr.get(k) for k in LUGRE_KEYS}
            v_max = self.ident.initial.get("v_max")     # as identify judged the baseline with
            v_max = float("nan") if v_max is None else v_max
            doc["identifiable"], own = judged(final, v_max)
            doc["fit"] = dict(doc["fit"], rms_error=final.rms, nrmse=final.nrmse,
                              fit_percent=100.0 * (1.0 - final.nrmse))
            # the LuGre-only fit's judgement of its values (not identifiable, not passive, the
            # Stribeck reach) speaks of the baseline: the model with its effects (an offset
            # absorbed into Fc; the linear stage's baseline bent to Fc ~ 1e-4 by a torque read
            # 0.92x its scale, "not passive") has its own, which stands in its place
            before = doc["baseline"]["warnings"] = doc.get("warnings", [])
            stale = set(judged(self.ident.result, v_max)[1])
            at = next((i for i, w in enumerate(before) if w in stale), len(before))
            doc["warnings"] = ([w for w in before[:at] if w not in stale] + own
                               + [w for w in before[at:] if w not in stale])
        self.clock_room.told(doc)
        doc["diagnosis"] = d.entries()
        doc["final"] = {"effects": d.model.names(),
                        "parameters": {k: float(v) for k, v in d.model.values.items()},
                        "rms_error": d.final_rms}
        doc["steps"] = [{"effect": s.effect, "forced": s.forced, "significant": s.significant,
                         "rms_before": s.rms_before, "rms_after": s.rms_after, "evidence": s.evidence,
                         "candidates": [{"effect": c.effect, "explained": c.explained,
                                         "explained_across_directions": c.explained_across,
                                         # null where not tested (not a position series)
                                         "explained_halves": (c.explained_halves if math.isfinite(c.explained_halves)
                                                              else None), "t": c.t_stat,
                                         "significant": c.significant} for c in s.screens]}
                        for s in d.steps]
        alpha = lugre["alpha"]
        data = self.ident.data
        residual = data.friction - d.contexts[-1].model     # the final model's
        doc["residuals"] = {
            "baseline": breakdown(self.ident.data, (data.friction - d.contexts[0].model if d.started_from
                                                    else self.ident.result.residual), alpha),
            "final": breakdown(self.ident.data, residual, alpha),
        }
        doc["unexplained"] = assess(doc["residuals"]["final"], d.final_rms, d.noise_floor,
                                    self.predictability(), data.coulomb, d.replay_rms,
                                    lugre=(doc["parameters"], doc["uncertainty"]),
                                    load_encoder=self.record.load_encoder,
                                    torque_unit="N·m" if data.revolute else "N",
                                    # the last round's terms: none is in the final model
                                    screens=[(c.effect, c.explained, c.removed_rms) for c in d.remaining],
                                    load=load_torque.carried(data.c, residual, data.mask)
                                    if data.inertia > 0 else None)
        if doc["unexplained"]["structured"]:
            structure_spread.widened(doc, *self.structure_spread(doc["uncertainty"]))
        chain_bias.widened(doc, self.chain_shift())
        undetermined_fit.told(doc, data.friction, 1.0 / data.c.dt, data.c.cutoff)   # a fit run off is not physics
        return doc

    def structure_spread(self, se: dict) -> tuple[dict, list]:
        """How far the final LuGre values move between halves of the record, and with the
        terms not credited that explain most of what is left (``bench.structure_spread``;
        computed once, as ``predictability``)."""
        if self._spread is None:
            d, data = self.diagnosis, self.ident.data
            self._spread = (structure_spread.spread(data, d.model, se),
                            structure_spread.stories(data, d.model, d.contexts[-1].model, d.remaining))
        return self._spread

    def chain_shift(self) -> dict:
        """How far the measurement chain alone moves the LuGre values (``bench.chain_bias``;
        computed once, as ``predictability``)."""
        if self._chain is None:
            d = self.diagnosis
            start = d.start.values if d is not None and d.start is not None else self.ident.result.values
            self._chain = chain_bias.shift(self.record, self.ident.data, start, self.ident.inertia)
        return self._chain

    def predictability(self) -> dict:
        """How much of the final residual the joint's state predicts on held-out segments
        (computed once: report() is called for the JSON, the HTML and the CLI)."""
        d = self.diagnosis
        if d.final_predictability is None:
            data = self.ident.data
            d.final_predictability = assess_predictability(data.c, data.friction - d.contexts[-1].model, d.cv)
        return d.final_predictability

    def reading(self) -> dict:
        return reading_section(self.record.reading, self.ident.data)

    def write_residuals(self, path: Path) -> Path:
        from bench.residual_csv import write_residuals
        return write_residuals(self, path)

    # --- pictures ---------------------------------------------------------------------------
    def write_plots(self, directory: Path) -> dict:
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        data, meta = self.ident.data, self.record.meta
        vals = self.ident.result.values
        files = {
            "map": plots.friction_map(data, vals, directory / "map.png", meta,
                                      title="Friction-velocity map: LuGre fit"),
            "presliding": plots.presliding(data, vals, directory / "presliding.png", meta),
            "inertia": plots.inertia_effect(data, self.ident.inertia, directory / "inertia_effect.png", meta),
        }
        if self.diagnosis is not None:
            d = self.diagnosis
            files["residual_baseline"] = plots.residual_panels(
                data, data.friction - d.contexts[0].model, vals["alpha"], directory / "residual_baseline.png",
                meta, "LuGre only")
            for i, (step, ctx) in enumerate(zip(d.steps, d.contexts[1:]), start=1):
                files[f"step{i}"] = plots.step_panels(data, d.contexts[i - 1].model, ctx.model,
                                                      directory / f"step{i}_{step.effect}.png", meta,
                                                      f"step {i}: + {step.effect}")
            files["error_fall"] = plots.error_fall(
                ["LuGre"] + [f"+ {s.effect}" for s in d.steps],
                [d.baseline_rms] + [s.rms_after for s in d.steps], directory / "error_fall.png", meta)
        self.plot_files = {k: Path(v) for k, v in files.items()}
        return self.plot_files

    def write_html(self, path: Path) -> Path:
        path = Path(path)
        if not self.plot_files:
            self.write_plots(path.parent / (path.stem + "_plots"))
        doc = self.report()
        path.write_text(render_html(self.name, doc, self.plot_files))
        return path


def analyze_record(rec: Record, inertia: float | str | None = None, add: list[str] | None = None,
                   diagnose_effects: bool = True, cutoff: float | None = None,
                   name: str = "record") -> Analysis:
    """Identify; then add the effects in ``add`` (forced, one step each) or, without
    ``add`` and unless ``diagnose_effects`` is False, the significant ones the diagnosis finds.
    ``inertia`` "estimate" (or the record's metadata saying so): read off the record."""
    from bench.friction_map import FrictionMap
    if isinstance(rec, FrictionMap):   # a row per steady speed (bench.map_analysis)
        from bench.map_analysis import analyze_map
        return analyze_map(rec, add, diagnose_effects, name)
    if add:  # validate names before spending time on a fit
        from bench.effects import get
        for n in add:
            get(n)
    if inertia_estimate.wanted(rec, inertia):
        return inertia_estimate.analyze(rec, add, diagnose_effects, cutoff, name)
    return _analyze(_ready(rec, inertia, name, cutoff), inertia, add, diagnose_effects, cutoff, name)


def _ready(rec: Record, inertia, name: str, cutoff: float | None) -> Record:
    """The record checked, its glitches mended and on its grid, as a file would be read."""
    memory = "raw_t" not in rec.reading       # built in memory: read as a file would be
    if memory:
        rec = spread(rec)                      # a coarse clock (a copy: the caller's record stays)
    record_magnitudes(rec, inertia, name)     # extreme numbers never reach the numerics
    if memory:
        rec = filled_forward(rec, inertia)     # a slower stream filled forward (a copy)
    if "glitches" not in rec.reading:          # built in memory (a drive's trace): screened as a file is
        rec = _glitches_mended(rec)
    rec = on_grid(rec, name)                   # a logger's timestamps, as a file would be read
    if cutoff is not None:
        in_range(cutoff, "cutoff", 0.0, 0.5 / max(rec.dt, 1e-12), lo_open=True)
    return rec


def _analyze(rec: Record, inertia, add, diagnose_effects: bool, cutoff, name: str) -> Analysis:
    with fit_errors():
        try:
            ident = identify(rec, inertia=inertia, cutoff=cutoff, name=name)
        except NotIdentifiable as refused:
            # a torque counting positive against the position reads as friction feeding energy
            # in; the same record with the torque reversed slides (the check is strict: a
            # clear Coulomb line in both directions), so it is analysed that way, and said
            try:
                rec = _torque_reversed(rec)
                ident = identify(rec, inertia=inertia, cutoff=cutoff, name=name)
            except NotIdentifiable:
                raise NotIdentifiable(with_hint(str(refused), rec, name)) from None
            ident.warnings.insert(0, REVERSED_WARNING)
        ident, rec, room = placed_in_room(ident, rec, name)    # a merged stream's clock
        step = torque_step(rec, ident.data.coulomb)
        ident.warnings[:0] = reading_warnings(rec, ident.data.coulomb, step, ident.data.held_poses,
                                              ident.data.c.velocity_source)
        diag = None
        if diagnose_effects or add:
            diag = _diagnose(ident, rec, add)
        if diag is not None and not add and cutoff is None and not gear_settled(diag):
            ident, diag = _wider_if_resonant(ident, diag, rec, name)
        if diag is not None:
            # the verdict on what is left counts a coarse torque reading's steps: a perfect
            # model read through them leaves a structure of its own.  Only the verdict: as the
            # floor while absorbers are weeded out (drop_absorbers) and as the chain's error in
            # an effect's own-physics checks, it let library effects that absorbed physics
            # outside the library stand as the story (a saturating torque constant told as
            # backlash on j2 and position-dependent friction on j4, tuning seeds 1382, 1384,
            # steps of 10 % of Fc)
            diag.replay_rms = max(diag.replay_rms, diag.stepped_replay_rms)
        if diag is not None:
            diag.beyond = None                 # served its purpose; its fits hold memory
        _check_finite(ident, diag)
    # stopped in the verdict's last steps (~20 % of a j4 analysis after its last fit): a run
    # cancelled then keeps no model either (bench.checkpoint)
    checkpoint()
    return Analysis(record=rec, ident=ident, diagnosis=diag, name=name, clock_room=room)


REVERSED_WARNING = ("the torque column counts positive against the position: at top speed the "
                    "friction opposed the motion in both directions, which friction cannot do; "
                    "the torque's sign was reversed (the parameters and residuals are for "
                    "the torque in the position's sense)")


def _glitches_mended(rec: Record) -> Record:
    """``rec`` with its position glitches mended (bench.glitches), the caller's record untouched:
    a real drive's encoder can glitch during a calibration as well as in a user's log."""
    from bench.glitches import mend_glitches
    out = replace(rec, q=np.array(rec.q, dtype=float), meta=dict(rec.meta), reading=dict(rec.reading))
    out.reading["glitches"] = mend_glitches(out)
    return out


def _torque_reversed(rec: Record) -> Record:
    """The record with its torque's sign reversed: a drive or sensor that counts positive the
    other way than the encoder (CiA 402's polarity object, a mirrored joint).  Friction's
    parameters do not depend on which one is reversed; the torque keeps the position's sense."""
    out = replace(rec, tau=-np.asarray(rec.tau), meta=dict(rec.meta), reading=dict(rec.reading))
    out.reading["torque_reversed"] = True
    return out


@contextmanager
def fit_errors():
    """A numerical failure inside the fit (a singular or non-finite problem that the
    boundary checks let through) is one clear InputError, never a traceback or a 500."""
    import numpy as np
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
            yield
    except BenchError:
        raise
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as e:
        raise InputError(f"the fit did not converge: {e.__class__.__name__}: {' '.join(str(e).split())[:200]}") from None


def _check_finite(ident: Identification, diag: Diagnosis | None) -> None:
    fits = [ident.result] + ([diag.model.result] if diag is not None else [])
    values = {k: v for r in fits for k, v in {**r.values, "rms": r.rms, "nrmse": r.nrmse}.items()}
    if diag is not None:
        values.update(baseline_rms=diag.baseline_rms, final_rms=diag.final_rms)
    bad = sorted(k for k, v in values.items() if isinstance(v, (int, float)) and not math.isfinite(v))
    if bad:
        raise InputError(f"the fit did not converge: non-finite {', '.join(bad)}")


def _diagnose(ident: Identification, rec: Record, add):
    """The diagnosis from the LuGre fit; where that fit left a level on a bound of its search,
    also from Section III's estimates (``bench.measured_start``), keeping whichever final
    model leaves the lower held-out error."""
    floor = noise_floor(ident.data.c, rec.tau, rec.q, ident.inertia, ident.data.mask)  # of the record, not the start
    fitted = _diagnose_from(ident, rec, add, ident.result, floor)
    start, note = measured_start(ident.result, ident.initial)
    if note is None:
        return fitted
    measured = _diagnose_from(ident, rec, add, start, floor)
    if not measured.final_rms < fitted.final_rms:
        return fitted
    measured.started_from = (f"{note} (its final model leaves {measured.final_rms:.4g} held out, "
                             f"the fit's {fitted.final_rms:.4g})")
    return measured


def _diagnose_from(ident: Identification, rec: Record, add, start, floor: float):
    """The diagnosis started from ``start`` (a LuGre fit's values); ``floor`` is the record's
    measurement-noise floor (``bench.unexplained.noise_floor``)."""
    data = ident.data
    twin, twin_residual = replay(rec, data, start.values, ident.inertia, data.c.cutoff)
    replay_rms = float(np.sqrt(np.mean(twin_residual[twin.mask] ** 2)))
    # a coarse torque reading's steps follow the motion: an effect must explain more of the
    # record than of a perfect model read through them (a position series took them on clean
    # j1 and j4, a cogging on the linear stage: steps of 15 % of Fc, seeds 5501-5506)
    step = torque_step(rec, ident.data.coulomb)
    stepped, stepped_rms = None, 0.0
    if step > 0 and not add:
        stepped, stepped_residual = replay(rec, data, start.values, ident.inertia, data.c.cutoff,
                                           tau_step=step)
        stepped_rms = float(np.sqrt(np.mean(stepped_residual[stepped.mask] ** 2)))
    # the effects see how the torque was read (held or sampled) as identification decided it
    meta = dict(rec.meta, torque_hold=ident.fit["torque_hold"])

    def run():
        diag = diagnose(data, start, meta, ident.inertia, add=add, auto=not add, twin=twin,
                        stepped_twin=stepped)
        diag.replay_rms, diag.noise_floor, diag.stepped_replay_rms = replay_rms, floor, stepped_rms
        if add:
            return diag

        def leftover(residual):
            p = diag.final_predictability = assess_predictability(data.c, residual, diag.cv)
            above = diag.final_rms / floor if floor > 0 else None
            if not structured(p, data.coulomb, diag.replay_rms, above):
                return [], 0.0
            if level_changes(p, data.coulomb):   # the level changes over time: time first
                return (["time"] + [k for k in p["relies_on"] if k != "time"],
                        max(p["structured_rms"], p["level"]["changing_rms"]))
            if rest_grows(p, data.coulomb) and not state_structured(p, data.coulomb, diag.replay_rms, above):
                return ["rest_before"], p["rest"]["growing_rms"]   # no effect has that signal
            return p["relies_on"], p["structured_rms"]
        return drop_absorbers(ident.data, diag, meta, ident.inertia, leftover)

    diag = run()
    # already with friction beyond the gear (the wide probe's retry), a second pass would
    # repeat the first exactly
    if add or friction_beyond_on() or not (
            gear_hysteresis_left(diag, data) or position_series_credited(diag)
            or inertia_like_spring(diag)):
        return diag
    # a structure left that follows the travel since the last reversal, as a gear's does, one
    # taken up by a position series, or an inertia error (or gravity) beside a spring's
    # signature: try again with friction beyond the gear, and keep
    # that only if it leaves nothing and predicts the held-out motion better
    with friction_beyond_gear():
        second = run()
    if beyond_wins(second, diag, data):
        return second
    diag.beyond = second
    return diag


def _wider_if_resonant(ident: Identification, diag: Diagnosis, rec: Record, name: str):
    """A gear spring above the comparison band (``bench.wide_band``): the analysis at the
    wider band replaces the default one when it names the spring and leaves no structure the
    default did not leave."""
    # a probe, not the analysis asked for: if the wider band cannot be fitted, the default stands
    try:
        probe = wider_band(rec, ident, MIN_EXPLAINED_SIZE, math.sqrt(ARTIFACT_RATIO), name)
        wide, wide_diag = probe[0] if probe else None, None
        if probe:
            wide_diag = _diagnose(wide, rec, None)
            # a spring with friction beyond it, as the probe saw, that the analysis without
            # it did not name, leaving structure: once more with friction beyond the gear (a
            # 14 Hz spring with 40 % of it beyond on j4 was fitted at 2.4 Hz, then dropped,
            # independent simulator, tuning seed 1972).  Not when nothing is left: dearer.
            if probe[1] and left_structured(wide_diag, wide.data):
                if wide_diag.beyond is not None:     # that pass ran already: the same
                    wide_diag = wide_diag.beyond
                else:
                    with friction_beyond_gear():
                        wide_diag = _diagnose(wide, rec, None)
            elif probe[1] and wide_diag.beyond is None and mimic_without_gear(wide_diag):
                # ...and when it was told, nothing left, as what such a spring passes for under
                # a sine: that pass competes, on _diagnose's terms (beyond_wins).  j1's
                # 13.35 Hz spring with 34 % of the friction beyond it was an inertia error
                # (independent simulator, tuning seed 1663): around it the spring scored 0.26
                # of what was left, below MIN_SHARE, so _diagnose's retry did not run.  True
                # inertia errors that get here keep their story (j3 1302, j4 1302, 1303, 1702
                # of 24 on tuning seeds), at up to 3x the analysis's time
                with friction_beyond_gear():
                    second = _diagnose(wide, rec, None)
                if beyond_wins(second, wide_diag, wide.data):
                    wide_diag = second
    except (BenchError, ValueError, ArithmeticError):    # LinAlgError is a ValueError
        return ident, diag
    if wide_diag is None or "joint_flexibility" not in wide_diag.model.names() \
            or (left_structured(wide_diag, wide.data) and not left_structured(diag, ident.data)):
        return ident, diag
    wide.warnings.append(widened_warning(ident.data.c.cutoff, wide.data.c.cutoff,
                                         wide_diag.model.values["flex_frequency"]))
    return wide, wide_diag
