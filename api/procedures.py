"""The bodies of the service's runs that procedures/ has no single entry point for:
identify one joint (excitation search, then identification and diagnosis) and a tracking
test with the joint's compensation off, on, or both.  Built from procedures' parts (Rig,
``search``, ``tracking_test``) and bench's (``analyze_record``, the store's models); a
calibration run calls ``procedures.calibration.calibrate`` itself (see ``api.run_child``).
Everything here runs in the run's own control process, not in the server.

A run's rig holds only that run's joints, so runs on other joints can go on beside it.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from bench.compensation import active_model
from bench.errors import InputError
from bench.lugre import LuGreParams
from bench.store import Store
from bench.traces import TraceWriter
from procedures.config import BenchConfig
from procedures.events import Cancel, Emitter, ProcedureFailed
from procedures.excitation import SearchSettings, search
from procedures.plugs import open_drives
from procedures.rig import Rig
from procedures.tracking import TrackingSettings, tracking_test

KINDS = {"identify": "identification", "tracking": "tracking", "calibrate": "calibration"}
PROCEDURE_OF_KIND = {v: k for k, v in KINDS.items()}


@dataclass
class Context:
    """What a run body needs; ``on_drives`` receives the guarded drives once they are open."""
    store: Store
    bench: BenchConfig
    transport: str                    # "virtual" (emulated CANopen/serial) | "simulated"
    run_id: str
    options: dict
    cancel: Cancel
    emit: Emitter
    wrap_drives: object               # callable(drives) -> guarded drives (api.safety.EStop.wrap)
    on_drives: object = None
    control: dict = field(default_factory=dict)

    @property
    def run_dir(self) -> Path:
        return self.store.run_dir(self.run_id)


def search_settings(options: dict) -> SearchSettings:
    st = SearchSettings()
    if options.get("search_max_trials") is not None:
        st = dataclasses.replace(st, max_trials=int(options["search_max_trials"]))
    if options.get("search_cycles") is not None:
        st = dataclasses.replace(st, cycles=float(options["search_cycles"]))
    return st


def tracking_settings(options: dict) -> TrackingSettings:
    st = TrackingSettings()
    if options.get("tracking_period") is not None:
        st = dataclasses.replace(st, period=float(options["tracking_period"]))
    if options.get("tracking_cycles") is not None:
        st = dataclasses.replace(st, cycles=float(options["tracking_cycles"]))
    return st


def sub_bench(cfg: BenchConfig, ids: list[str]) -> BenchConfig:
    return BenchConfig(name=cfg.name, joints=[cfg.joint(i) for i in ids], control_period=cfg.control_period,
                       clock=cfg.clock, description=cfg.description, source=cfg.source, raw=cfg.raw)


# --- the rig of one run -----------------------------------------------------------------------
def open_rig(ctx: Context, ids: list[str]) -> Rig:
    """Emulated drives for the run's joints (VirtualBench, reached over the real CANopen /
    serial stacks) or in-process simulated plugs; guarded for the e-stop; enabled, holding."""
    cfg = sub_bench(ctx.bench, ids)
    seed = int(ctx.options.get("seed", 0))
    vb, joints = None, cfg.joints
    if ctx.transport == "virtual":
        from virtual_drives.launch import VirtualBench
        vb = VirtualBench(cfg.joints, clock=cfg.clock, control_period=cfg.control_period, seed=seed)
        vb.start()
        joints = vb.joints
    drives: dict = {}
    try:
        drives = open_drives(joints, force_simulated=ctx.transport == "simulated", seed=seed,
                             control_period=cfg.control_period, clock=cfg.clock)
        drives = ctx.wrap_drives(drives)
        if ctx.on_drives is not None:
            ctx.on_drives(drives)
        rig = Rig(cfg, drives, ctx.cancel)
        rig.virtual_bench = vb
        rig.parked = False
        ctx.control["host_overruns_start"] = pacer_overruns(cfg)
        rig.start()
    except BaseException:
        for d in drives.values():
            try:
                d.close()
            except Exception:
                pass
        if vb is not None:
            vb.close()
        raise
    return rig


def close_rig(ctx: Context, rig: Rig) -> None:
    """Bring the joints to rest and power off (e-stop if that fails), read the overrun
    counters, close the drives and the emulators.  Never raises."""
    try:
        if not rig.parked:
            rig.park()
    except Exception:
        rig.emergency_stop()
    vb = getattr(rig, "virtual_bench", None)
    drive_overruns = {}
    if vb is not None:
        for jid in rig.ids:
            try:
                drive_overruns[jid] = int(vb.drive(jid).snapshot().get("overruns", 0))
            except Exception:
                pass
    for d in rig.drives.values():
        try:
            d.close()
        except Exception:
            pass
    if vb is not None:
        vb.close()
    start = ctx.control.pop("host_overruns_start", None)
    end = pacer_overruns(rig.cfg)
    ctx.control.update(clock=rig.cfg.clock, cycles=rig.k, drive_overruns=drive_overruns,
                       host_overruns=None if start is None or end is None else end - start)


def pacer_overruns(cfg: BenchConfig) -> int | None:
    """The host pacer's overrun count (realtime clock only; shared by every rig in this
    process with the same clock and period: in the service, one run's control process)."""
    if cfg.clock != "realtime":
        return 0
    try:
        from drivers.pacing import Pacer
    except ImportError:
        return None
    return Pacer.shared(cfg.clock, cfg.control_period).overruns


def attach_trace(ctx: Context, rig: Rig) -> TraceWriter:
    rig.trace = TraceWriter(ctx.run_dir, rig.trace_columns(), meta={"run_id": ctx.run_id})
    return rig.trace


def _resume(rig: Rig) -> None:
    if rig.parked:
        rig.start()
        rig.parked = False


# --- identify ----------------------------------------------------------------------------------
def identify_joint(ctx: Context, rig: Rig, jid: str) -> dict:
    from bench.analysis import analyze_record
    _resume(rig)
    ctx.emit.event("stage", joint=jid, stage="search", status="running")
    res = search(rig, jid, search_settings(ctx.options), ctx.emit)
    ctx.emit.event("stage", joint=jid, stage="search", status="done" if res.ok else "failed",
                   reason=None if res.ok else res.reason)
    if not res.ok:
        raise ProcedureFailed(f"{jid}: {res.reason}")
    res.record.to_csv(ctx.run_dir / f"record-{jid}.csv")
    rig.park()                  # nobody cycles the drives while fitting: power off, not starve
    rig.parked = True
    ctx.cancel.check()
    ctx.emit.event("stage", joint=jid, stage="identify", status="running")
    with ctx.cancel.during_fit():
        analysis = analyze_record(res.record, inertia=res.record.inertia, name=f"{jid} (run {ctx.run_id})")
    report = analysis.report()
    params = LuGreParams.from_dict(report["parameters"])
    model_id = ctx.store.add_model(jid, params.as_dict(), report, ctx.run_id)
    if ctx.options.get("plots", True):
        analysis.write_html(ctx.run_dir / f"report-{jid}.html")
    ctx.emit.event("model", joint=jid, model_id=model_id, parameters=report["parameters"])
    ctx.emit.event("stage", joint=jid, stage="identify", status="done")
    return {"model_id": model_id, "parameters": report["parameters"],
            "uncertainty": report.get("uncertainty"), "identifiable": report.get("identifiable"),
            "fit": report.get("fit"), "diagnosis": report.get("diagnosis", []),
            "effects": (report.get("final") or {}).get("effects", []),
            "warnings": report.get("warnings", []),
            "excitation": {"amplitude": res.amplitude, "frequency": res.frequency,
                           "trials": len(res.trials)}}


def _park(rig: Rig) -> None:
    """Drawing a plot takes a while with nobody cycling the drives: park them (at rest,
    powered off) rather than starve their watchdogs."""
    if not rig.parked:
        rig.park()
        rig.parked = True


# --- tracking ----------------------------------------------------------------------------------
def tracking_models(store: Store, jid: str, options: dict) -> tuple[dict, str | None]:
    """{label: params or None} for the requested compensation, and the model id used.
    Raises InputError (checked before the run starts, so the caller gets a 4xx)."""
    mode = options.get("compensation", "current")
    model_id = options.get("model")
    if model_id is not None:
        m = store.get_model(model_id)
        if m["joint_id"] != jid:
            raise InputError(f"options.model: model {model_id!r} belongs to joint {m['joint_id']!r}, not {jid!r}")
    if mode == "current" and model_id is None:
        params = active_model(store, jid)
        return {"on" if params is not None else "off": params}, (
            store.get_compensation(jid)["model_id"] if params is not None else None)
    if mode == "off":
        return {"off": None}, None
    if model_id is None:
        model_id = store.get_compensation(jid)["model_id"]
        if model_id is None:
            models = store.list_models(jid)
            if not models:
                raise InputError(f"joint {jid!r} has no identified model to compensate with; identify it first")
            model_id = models[0]["id"]
    params = LuGreParams.from_dict(store.get_model(model_id)["params"])
    if mode == "both":
        return {"off": None, "on": params}, model_id
    return {"on": params}, model_id


def tracking_joint(ctx: Context, rig: Rig, jid: str) -> dict:
    _resume(rig)
    models, model_id = tracking_models(ctx.store, jid, ctx.options)
    ctx.emit.event("stage", joint=jid, stage="tracking", status="running", variants=list(models))
    plot = ctx.run_dir / f"tracking-{jid}.png" if ctx.options.get("plots", True) else None
    res = tracking_test(rig, jid, models, tracking_settings(ctx.options), ctx.emit, plot=plot,
                        before_plot=lambda: _park(rig))
    ctx.emit.event("stage", joint=jid, stage="tracking", status="done")
    out = {"compensation": "both" if len(models) > 1 else next(iter(models)), "model_id": model_id,
           "variants": {k: res[k] for k in models}}
    if len(models) == 1:
        out.update(res[next(iter(models))])
    else:
        out["improvement"] = res["off"]["rms_error"] / max(res["on"]["rms_error"], 1e-300)
    if "plot" in res:
        out["plot"] = Path(res["plot"]).name
    return out


BODIES = {"identify": identify_joint, "tracking": tracking_joint}


# --- calibration summary --------------------------------------------------------------------
def calibration_summary(report: dict) -> dict:
    """Per joint: status, reason, identified parameters and the tracking errors."""
    joints = {}
    for jid, j in (report.get("joints") or {}).items():
        st = j.get("stages", {})
        ident = (st.get("identify") or {}).get("result") or {}
        val = (st.get("validate") or {}).get("result") or {}
        joints[jid] = {"status": j.get("status"), "reason": j.get("reason"),
                       "model_id": ident.get("model_id"), "parameters": ident.get("parameters"),
                       "diagnosis": ident.get("diagnosis"),
                       "tracking": {"off": val.get("none"), "on": val.get("identified"),
                                    "improvement": val.get("improvement")} if val else None}
    return joints
