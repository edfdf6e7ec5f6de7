"""Overnight calibration: for each chosen joint, search -> identify -> validate by tracking.

Unattended and resumable.  The plan (one entry per joint and stage) lives in the calibration
run's result in the store and is saved after every stage, so a process killed mid-run
leaves a run that ``Store.recover`` marks interrupted and ``calibrate(..., resume=True)``
continues: finished stages are kept, the interrupted one is redone.  Each stage that moves a
joint is a child run with its own trace.  A failing joint is recorded with its reason and the
plan moves on to the next joint.  The end is one report (JSON + HTML) in the run directory.
"""
from __future__ import annotations

import dataclasses
import html
import json
from pathlib import Path
from typing import Callable

from bench.errors import BenchError, InputError
from bench.lugre import LuGreParams
from bench.records import read_csv
from bench.store import Store
from bench.traces import TraceWriter
from drivers.realtime import describe
from procedures.config import BenchConfig, load_bench
from procedures.events import Cancel, Cancelled, Emitter, ProcedureFailed, Sink
from procedures.excitation import SearchSettings, search
from procedures.plugs import open_drives
from procedures.rig import Rig
from procedures.tracking import TrackingSettings, plot_map, tracking_test

STAGES = ("search", "identify", "validate")


@dataclasses.dataclass
class CalibrationSettings:
    search: SearchSettings = dataclasses.field(default_factory=SearchSettings)
    tracking: TrackingSettings = dataclasses.field(default_factory=TrackingSettings)
    # False: the bench's emulated CANopen / serial drives (VirtualBench, lock-step) reached
    # through the driver registry, i.e. the real protocol stacks; True: in-process plugs
    force_simulated: bool = False
    # True: the drives the bench configuration names, as they are (real hardware, or drives
    # someone else runs): no emulators are started
    hardware: bool = False
    plots: bool = True
    # called with the freshly opened drives {joint id: drive}, returns the drives the rig uses:
    # the REST service wraps them so its e-stop reaches every open drive (api.safety)
    wrap_drives: Callable[[dict], dict] | None = None


def start_calibration(store: Store, bench: str | Path, joints: list[str] | None = None, seed: int = 0,
                      options: dict | None = None, transport: str | None = None) -> str:
    """Create a queued calibration run with its plan; returns the run id.  ``options`` and
    ``transport`` are kept in the run's config, so the record says how it was asked for."""
    cfg = load_bench(bench)
    ids = cfg.select(joints)
    plan = [{"joint": j, "stage": s, "status": "pending"} for j in ids for s in STAGES]
    run_id = store.create_run("calibration", config={"bench": str(bench), "joints": ids, "bench_config": cfg.raw,
                                                     "options": dict(options or {}), "transport": transport},
                              seed=seed, state="queued")
    store.set_result(run_id, {"plan": plan})
    return run_id


def latest_resumable(store: Store, bench: str | Path | None = None) -> str:
    store.recover()
    for r in store.list_runs(kind="calibration"):
        if r["state"] in ("interrupted", "cancelled", "queued") and (bench is None or r["config"]["bench"] == str(bench)):
            return r["id"]
    raise InputError("nothing to resume: no interrupted calibration run" + (f" for bench {bench}" if bench else ""))


def calibrate(store: Store, run_id: str, on_event: Sink | None = None, cancel: Cancel | None = None,
              settings: CalibrationSettings | None = None) -> dict:
    """Run (or resume) calibration ``run_id`` to its end; returns the report."""
    st = settings or CalibrationSettings()
    cancel = cancel or Cancel()
    run = store.get_run(run_id)
    cfg = load_bench(run["config"]["bench"])
    plan = run["result"]["plan"]
    store.claim(run_id)
    emit = Emitter(run_id, [store.emit, on_event], first_seq=store.last_seq(run_id) + 1)
    emit.start(kind="calibration", bench=cfg.name, joints=run["config"]["joints"],
               resumed=any(p["status"] != "pending" for p in plan), seed=run["seed"])
    rig = None
    state = "succeeded"
    drivers: dict[str, str] = {}     # joint -> driver class that moved it (this process)
    try:
        for step in plan:
            if step["status"] in ("done", "failed", "skipped"):
                continue
            if _joint_failed(plan, step["joint"]):
                step.update(status="skipped", reason="an earlier stage of this joint failed")
                continue
            cancel.check()
            step["status"] = "running"
            store.set_result(run_id, {"plan": plan})
            emit.event("stage", joint=step["joint"], stage=step["stage"], status="running")
            try:
                if step["stage"] == "identify":
                    if rig is not None:
                        _park(rig)  # nobody cycles the drives while fitting: disable, not starve
                else:
                    try:
                        rig = _ready_rig(rig, cfg, run["seed"] or 0, cancel, st, emit, step)
                    except BenchError:
                        rig = None  # closed by _ready_rig
                        raise
                    drivers.update({j: type(d).__name__ for j, d in rig.drives.items()})
                with cancel.during_fit():   # an identify stage's fit stops at a cancel too
                    _STAGE_FUNCS[step["stage"]](store, cfg, rig, plan, step, emit, st, run_id)
                step["status"] = "done"
            except Cancelled:
                step["status"] = "pending"
                raise
            except BenchError as e:
                step.update(status="failed", reason=str(e))
                if rig is not None:  # a failed stage may have stopped the drives: start afresh
                    _close(rig)
                    rig = None
            emit.event("stage", joint=step["joint"], stage=step["stage"], status=step["status"],
                       reason=step.get("reason"))
            store.set_result(run_id, {"plan": plan})
    except Cancelled as e:
        state = "cancelled"
        emit.event("cancelled", reason=str(e))
    finally:
        if rig is not None:
            _close(rig)
    report = build_report(store, run_id, cfg, plan, drivers=drivers, transport=transport_name(st))
    store.finish_run(run_id, state, result={"plan": plan, "report": report})
    emit.stop(state, joints={j: r["status"] for j, r in report["joints"].items()})
    return report


def _joint_failed(plan, joint) -> bool:
    return any(p["joint"] == joint and p["status"] == "failed" for p in plan)


def _park(rig: Rig) -> None:
    """Bring every joint to rest and power the drives off (holding brakes engage) before the
    host computes or writes files for a while: a drive left enabled but no longer cycled would
    starve its watchdog.  The next moving stage enables them again."""
    if not rig.parked:
        rig.parked = True
        rig.park()


def _ready_rig(rig: Rig | None, cfg: BenchConfig, seed: int, cancel: Cancel, st: CalibrationSettings,
               emit: Emitter, step: dict) -> Rig:
    """The rig, open and enabled, for a stage that moves a joint.  A bench that fails to open
    or enable is closed and opened afresh once (a transient communication error on a loaded
    host); a second failure fails the stage with its reason."""
    for attempt in (1, 2):
        try:
            if rig is None:
                rig = _open_rig(cfg, seed, cancel, st)
            elif rig.parked:
                rig.start()
                rig.parked = False
            return rig
        except BenchError as e:
            if rig is not None:
                _close(rig)
                rig = None
            if attempt == 2:
                raise
            emit.event("retry", joint=step["joint"], stage=step["stage"], reason=str(e))
    raise AssertionError("unreachable")


def transport_name(st: CalibrationSettings) -> str:
    return "simulated" if st.force_simulated else "hardware" if st.hardware else "virtual"


def _open_rig(cfg: BenchConfig, seed: int, cancel: Cancel, st: CalibrationSettings) -> Rig:
    """Simulated plugs in-process, the configured drives as they are (``hardware``), or the
    emulated CANopen/serial drives of a lock-step virtual bench reached through the driver
    registry."""
    vb, joints = None, cfg.joints
    if not st.force_simulated and not st.hardware:
        from virtual_drives.launch import VirtualBench  # the bench's drive side, not a driver
        check_virtual(cfg)
        vb = VirtualBench(cfg.joints, clock=cfg.clock, control_period=cfg.control_period, seed=seed)
        try:
            vb.start()
        except BenchError:
            raise
        except Exception as e:  # an emulator that cannot start is this stage's failure, not a crash
            raise ProcedureFailed(f"cannot start the virtual drives: {e.__class__.__name__}: {e}") from None
        joints = vb.joints
    try:
        drives = open_drives(joints, force_simulated=st.force_simulated, seed=seed,
                             control_period=cfg.control_period, clock=cfg.clock)
        if st.wrap_drives is not None:
            drives = st.wrap_drives(drives)
        rig = Rig(cfg, drives, cancel)
        rig.virtual_bench = vb
        rig.parked = False
        rig.start()
    except BaseException:
        if vb is not None:
            vb.close()
        raise
    return rig


def check_virtual(cfg: BenchConfig) -> None:
    """The virtual transport emulates each drive from its joint's ``preset`` or ``physics``
    table (the physical truth); a bench without either (real hardware) cannot be emulated."""
    for j in cfg.joints:
        if j["transport"] != "simulated" and not j.get("preset") and not j.get("physics"):
            raise InputError(f"joint {j['id']!r} has no preset: the virtual transport emulates each "
                             f"drive from its joint's preset (give preset = \"<name>\") or its "
                             f"physics ([joints.physics], see docs/procedures.md)")


def _close(rig: Rig) -> None:
    try:
        rig.trace = None
        if not getattr(rig, "parked", False):
            rig.park()
    except Exception:
        rig.emergency_stop()
    for d in rig.drives.values():
        try:
            d.close()
        except Exception:
            pass
    if getattr(rig, "virtual_bench", None) is not None:
        rig.virtual_bench.close()


def _child(store, run_id, rig, kind, jid, emit, seed):
    child = store.create_run(kind, parent_id=run_id, joint_id=jid, seed=seed)
    rig.trace = TraceWriter(store.run_dir(child), rig.trace_columns(), meta={"run_id": child, "joint": jid})
    emit.event("child", joint=jid, kind=kind, child_run=child)
    return child, emit.child(child)


def _stage_search(store, cfg, rig, plan, step, emit, st, run_id):
    jid = step["joint"]
    child, cemit = _child(store, run_id, rig, "excitation", jid, emit, store.get_run(run_id)["seed"])
    step["run_id"] = child
    cemit.start(kind="excitation", joint=jid)
    try:
        res = search(rig, jid, st.search, cemit)
        _park(rig)      # the files below take a while; the next stage (identify) parks anyway
    except BaseException as e:
        _end_child(store, rig, child, cemit, "cancelled" if isinstance(e, Cancelled) else "failed", error=str(e))
        raise
    summary = res.summary()
    d = store.run_dir(child)
    for lv in res.levels:
        if lv.get("record") is not None:
            lv["record"].to_csv(d / f"record-level-{lv['level']:g}.csv")
    if res.ok:
        res.record.to_csv(d / "record.csv")
        summary["record"] = str(d / "record.csv")
    _end_child(store, rig, child, cemit, "succeeded" if res.ok else "failed", summary, None if res.ok else res.reason)
    step["result"] = {k: summary[k] for k in ("amplitude", "frequency", "waveform", "reason")} | {
        "trials": len(res.trials), "record": summary.get("record")}
    if not res.ok:
        raise _StageFailed(res.reason)


def _end_child(store, rig, child, cemit, state, result=None, error=None):
    if rig.trace is not None:
        rig.trace.close()
        rig.trace = None
    store.finish_run(child, state, result=result, error=error)
    cemit.stop(state, reason=error)


def _stage_identify(store, cfg, rig, plan, step, emit, st, run_id):
    jid = step["joint"]
    search_step = next(p for p in plan if p["joint"] == jid and p["stage"] == "search")
    rec = read_csv(search_step["result"]["record"])
    report, params = identify_record(rec)
    d = store.run_dir(search_step["run_id"])
    if st.plots:
        maps = [("accepted", rec)] + [(p.stem, read_csv(p)) for p in sorted(d.glob("record-level-*.csv"))
                                      if not p.stem.endswith("-1")]
        report["map_plot"] = str(plot_map(maps, rec.inertia, d / "map.png", params))
    model_id = store.add_model(jid, params.as_dict(), report, search_step["run_id"])
    emit.event("model", joint=jid, model_id=model_id, parameters=report["parameters"])
    step["result"] = {"model_id": model_id, "parameters": report["parameters"],
                      "identifiable": report["identifiable"], "fit": report.get("fit"),
                      "diagnosis": report.get("diagnosis", []), "map_plot": report.get("map_plot")}


def identify_record(rec) -> tuple[dict, LuGreParams]:
    """bench.analysis (identification + discrepancy diagnosis) when it is usable, else
    bench.identify alone.  The model to compensate with is the identified LuGre."""
    try:
        from bench.analysis import analyze_record
    except (ImportError, SyntaxError) as e:
        from bench.identify import identify
        ident = identify(rec)
        report = ident.report()
        report.setdefault("warnings", []).append(f"analysis unavailable ({e.__class__.__name__})")
        return report, ident.params
    analysis = analyze_record(rec, inertia=rec.inertia)
    report = analysis.report()
    return report, LuGreParams.from_dict(report["parameters"])


def _stage_validate(store, cfg, rig, plan, step, emit, st, run_id):
    jid = step["joint"]
    ident = next(p for p in plan if p["joint"] == jid and p["stage"] == "identify")
    params = LuGreParams.from_dict(ident["result"]["parameters"])
    child, cemit = _child(store, run_id, rig, "tracking", jid, emit, store.get_run(run_id)["seed"])
    step["run_id"] = child
    cemit.start(kind="tracking", joint=jid, model_id=ident["result"]["model_id"])
    try:
        res = tracking_test(rig, jid, {"none": None, "identified": params}, st.tracking, cemit,
                            plot=store.run_dir(child) / "tracking.png" if st.plots else None,
                            before_plot=lambda: _park(rig))
    except BaseException as e:
        _end_child(store, rig, child, cemit, "cancelled" if isinstance(e, Cancelled) else "failed", error=str(e))
        raise
    _end_child(store, rig, child, cemit, "succeeded", res)
    step["result"] = res


class _StageFailed(BenchError):
    pass


_STAGE_FUNCS = {"search": _stage_search, "identify": _stage_identify, "validate": _stage_validate}


def build_report(store: Store, run_id: str, cfg: BenchConfig, plan: list[dict],
                 drivers: dict | None = None, transport: str | None = None) -> dict:
    joints = {}
    for step in plan:
        j = joints.setdefault(step["joint"], {"status": "succeeded", "reason": None, "stages": {}})
        j["stages"][step["stage"]] = {k: v for k, v in step.items() if k not in ("joint", "stage")}
        if step["status"] == "failed" and j["reason"] is None:
            j["status"], j["reason"] = "failed", f"{step['stage']}: {step.get('reason')}"
        elif step["status"] in ("pending", "running") and j["status"] == "succeeded":
            j["status"] = "incomplete"
    report = {"run_id": run_id, "bench": cfg.name, "joints": joints, "transport": transport,
              "control_period": cfg.control_period, "clock": cfg.clock, "drivers": drivers or {},
              "scheduling": describe()}      # this process's policy, priority and CPUs
    d = store.run_dir(run_id)
    (d / "report.json").write_text(json.dumps(report, indent=2, default=str))
    (d / "report.html").write_text(_html(report))
    report["files"] = {"json": str(d / "report.json"), "html": str(d / "report.html")}
    return report


def _html(report: dict) -> str:
    e = html.escape
    rows = []
    for jid, j in report["joints"].items():
        ident = j["stages"].get("identify", {}).get("result") or {}
        track = j["stages"].get("validate", {}).get("result") or {}
        params = ", ".join(f"{k}={v:.4g}" for k, v in (ident.get("parameters") or {}).items())
        rms = ""
        if "none" in track:
            rms = (f"{track['none']['rms_error']:.3g} &rarr; {track['identified']['rms_error']:.3g} "
                   f"(&times;{track.get('improvement', float('nan')):.1f})")
        imgs = "".join(f'<img src="{e(p)}" width="360">' for p in (ident.get("map_plot"), track.get("plot")) if p)
        rows.append(f"<tr><td>{e(jid)}</td><td>{e(j['status'])}</td><td>{e(j['reason'] or '')}</td>"
                    f"<td>{e(params)}</td><td>{rms}</td><td>{imgs}</td></tr>")
    return ("<!doctype html><meta charset='utf-8'><title>Calibration " + e(report["run_id"]) + "</title>"
            "<style>td,th{border:1px solid #ccc;padding:4px;vertical-align:top}</style>"
            f"<h1>Calibration of {e(report['bench'])}</h1><p>run {e(report['run_id'])}</p>"
            "<table><tr><th>joint</th><th>status</th><th>reason</th><th>parameters</th>"
            "<th>tracking RMS error: off &rarr; on</th><th>plots</th></tr>" + "".join(rows) + "</table>")
