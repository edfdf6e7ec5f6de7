"""/runs: start, list, watch (SSE), cancel, trace and report."""
from __future__ import annotations

from typing import Optional

import anyio
from fastapi import APIRouter, Depends, Header, Query, Request, Response
from fastapi.responses import HTMLResponse, StreamingResponse

from api import errors as E
from api import feed
from api.deps import Service, observer, operator, service
from api.models import RunCreated, RunInfo, RunList, RunRequest, RunState
from api.procedures import KINDS, PROCEDURE_OF_KIND
from api.reports import run_report, trace_csv
from api.runs import NotFound
from bench.errors import InputError
from bench.store import FINAL

router = APIRouter(tags=["runs"], responses={**E.AUTH})
RUN_CACHE_SIZE = 512


def get_run(svc: Service, run_id: str) -> dict:
    if len(run_id) > 128:
        raise NotFound(f"no run {run_id[:40]!r}...")
    try:
        return svc.store.get_run(run_id)
    except InputError:
        raise NotFound(f"no run {run_id!r}") from None


def procedure_of(run: dict) -> str:
    return PROCEDURE_OF_KIND.get(run["kind"], run["kind"]) if run.get("parent_id") is None else run["kind"]


def run_info(svc: Service, run: dict) -> RunInfo:
    cfg = run.get("config") or {}
    joints = cfg.get("joints") or ([run["joint_id"]] if run.get("joint_id") else [])
    result = None
    if run["state"] in FINAL:
        result = dict(run.get("result") or {})
        result.pop("plan", None)            # the calibration's working state; "joints" summarises it
        rep = result.pop("report", None)
        if isinstance(rep, dict) and rep.get("files"):
            result["files"] = rep["files"]
    return RunInfo(id=run["id"], procedure=procedure_of(run), kind=run["kind"], state=run["state"],
                   progress=float(min(1.0, max(0.0, svc.runs.progress(run)))), joints=list(joints),
                   parent_id=run.get("parent_id"), created=run["created"], started=run.get("started"),
                   ended=run.get("ended"), error=run.get("error"), options=cfg.get("options") or {},
                   result=result)


@router.post("/runs", status_code=202, response_model=RunCreated, responses={**E.NOT_FOUND, **E.CONFLICT},
             summary="Start an identification, tracking or calibration run")
def create_run(body: RunRequest, response: Response, svc: Service = Depends(service), _=Depends(operator)):
    h = svc.runs.start(body.procedure, body.joints, body.options.model_dump())
    location = f"/runs/{h.run_id}"
    response.headers["Location"] = location
    return RunCreated(id=h.run_id, procedure=body.procedure, state="queued", joints=h.joints, location=location)


@router.get("/runs", response_model=RunList, summary="Runs, newest first")
def list_runs(procedure: Optional[str] = Query(None, pattern="^(identify|tracking|calibrate)$"),
              state: Optional[RunState] = None, joint: Optional[str] = Query(None, max_length=64),
              limit: int = Query(50, ge=1, le=500), svc: Service = Depends(service), _=Depends(observer)):
    kind = KINDS[procedure] if procedure else None
    rows = [r for r in svc.store.list_runs(kind=kind, state=state, limit=2000) if r.get("parent_id") is None]
    if joint is not None:
        rows = [r for r in rows if joint in ((r.get("config") or {}).get("joints") or [])]
    return RunList(runs=[run_info(svc, r) for r in rows[:limit]])


@router.get("/runs/{run_id}", response_model=RunInfo, responses={**E.NOT_FOUND}, summary="One run")
async def read_run(run_id: str, svc: Service = Depends(service), _=Depends(observer)):
    # Polled by every technician's screen while a run goes on.  The record is read again
    # only when the store has changed (api.cache), the answer re-encoded only when the
    # progress (relayed by the run's process) has moved, and kept for good once the run has
    # ended: most polls cost neither a thread hop nor a SQLite read nor a serialisation.
    v = svc.version.current()
    hit = svc.run_cache.get(run_id)
    if hit is not None:
        version, run, progress, body = hit
        if version is None:                         # ended: final
            return Response(body, media_type="application/json")
        if v is not None and version == v:
            if svc.runs.progress(run) != progress:
                body = _encode(svc, run_id, run, v)
            return Response(body, media_type="application/json")
    run = await anyio.to_thread.run_sync(get_run, svc, run_id)
    return Response(_encode(svc, run_id, run, v), media_type="application/json")


def _encode(svc: Service, run_id: str, run: dict, version: int | None) -> bytes:
    info = run_info(svc, run)
    body = info.model_dump_json().encode()
    active = run["id"] in svc.runs.handles or run["state"] not in FINAL
    if active and version is None:      # the store's version unknown: not kept
        svc.run_cache.pop(run_id, None)
        return body
    svc.run_cache[run_id] = (version if active else None, run, info.progress, body)
    svc.run_cache.move_to_end(run_id)
    while len(svc.run_cache) > RUN_CACHE_SIZE:
        svc.run_cache.popitem(last=False)
    return body


@router.post("/runs/{run_id}/cancel", status_code=202, response_model=RunInfo, responses={**E.NOT_FOUND},
             summary="Controlled ramp-down; the run ends 'cancelled' (a finished run is left as it is)")
def cancel_run(run_id: str, svc: Service = Depends(service), _=Depends(operator)):
    run = get_run(svc, run_id)
    svc.runs.cancel(run_id)
    return run_info(svc, run)


@router.get("/runs/{run_id}/trace.csv", response_class=Response, responses={
    **E.non_json(401, 413, 429, 403, 404, 409, 422),
    200: {"content": {"text/csv": {"schema": {"type": "string"}}}, "description": "record CSV"}},
    summary="One joint's trace as a record CSV (partial while running or after a cancel)")
def read_trace_csv(run_id: str, joint: Optional[str] = Query(None, max_length=64),
                   every: int = Query(1, ge=1, le=1000, description="keep every n-th sample"),
                   svc: Service = Depends(service), _=Depends(observer)):
    run = get_run(svc, run_id)
    joints = (run.get("config") or {}).get("joints") or ([run["joint_id"]] if run.get("joint_id") else [])
    jid = joint or (joints[0] if joints else None)
    if jid is None:
        raise NotFound(f"run {run_id} has no joints")
    text = trace_csv(svc.store, svc.cfg, run, jid, every)
    return Response(text, media_type="text/csv",
                    headers={"Content-Disposition": f'attachment; filename="{run_id}-{jid}.csv"'})


@router.get("/runs/{run_id}/report", response_class=HTMLResponse, responses={
    **E.non_json(401, 413, 429, 403, 404, 409, 422),
    200: {"content": {"text/html": {"schema": {"type": "string"}}}, "description": "HTML report"}},
    summary="HTML report with the plots")
def read_report(run_id: str, joint: Optional[str] = Query(None, max_length=64),
                svc: Service = Depends(service), _=Depends(observer)):
    run = get_run(svc, run_id)
    return HTMLResponse(run_report(svc.store, run, procedure_of(run), joint))


# one server-sent event: its `data:` line is a JSON object, never a bare string
SSE_EVENT = {
    "type": "object", "required": ["event", "data"],
    "properties": {
        "id": {"type": "integer", "description": "the document's sequence number (documents only)"},
        "event": {"type": "string", "description": "start, stage, trial, model, tracking, cancelled, stop "
                                                  "(the run's documents), progress, sample, end"},
        "data": {"type": "object", "description": "the document's data, {progress}, {joint: sample}, {state}"}}}


@router.get("/runs/{run_id}/events", response_class=StreamingResponse, responses={
    **E.non_json(401, 413, 429, 403, 404, 422), 200: {"content": {"text/event-stream": {
        "schema": {"type": "string", "description": "a stream of events, each as SSE_EVENT describes"},
        "itemSchema": SSE_EVENT}},     # OpenAPI 3.2's schema of each item of a sequential media type
        "description": "server-sent events until the run ends: `id:` (documents only), `event:` (the name), "
                       "`data:` (one JSON object)"}},
    summary="Live: the run's documents (stages, trials, models, tracking), progress, decimated samples")
async def run_events(request: Request, run_id: str,
                     after: int = Query(-1, ge=-1, le=2**31, description="resume after this event id"),
                     sample_hz: float = Query(10.0, ge=0.0, le=50.0, allow_inf_nan=False, description="live sample rate (0: none)"),
                     last_event_id: Optional[str] = Header(None, max_length=20),
                     svc: Service = Depends(service), _=Depends(observer)):
    await anyio.to_thread.run_sync(get_run, svc, run_id)
    if last_event_id is not None and last_event_id.strip().lstrip("-").isdigit():
        after = max(after, int(last_event_id))
    return StreamingResponse(feed.stream(request, svc, run_id, after, sample_hz), media_type="text/event-stream",
                             headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})
