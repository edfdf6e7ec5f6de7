"""/health, /estop, /keys, /effects and /analyze."""
from __future__ import annotations

import asyncio
import email.parser
import email.policy
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Optional

from fastapi import APIRouter, Depends, HTTPException, Query, Request, Response

import bench
from api import errors as E
from api.auth import Principal
from api.deps import Service, admin, observer, operator, principal, service
from api.limits import MAX_UPLOAD        # the body cap itself is enforced by api.limits.BodyLimit
from api.models import EffectInfo, EffectList, EStopState, Health, KeyCreate, KeyCreated, KeyInfo, KeyList
from api.runs import Conflict, NotFound
from bench.errors import InputError

router = APIRouter()
# s between two looks at an /analyze client while its analysis runs (a look is a poll of the
# connection's receive channel, microseconds)
POLL_DISCONNECT = 0.5


@router.get("/health", response_model=Health, tags=["service"], summary="Liveness (no key needed)")
async def health(svc: Service = Depends(service)):
    # polled by every open page every second: memory only, so async (a sync handler costs a
    # worker thread for the handler and another for validating its answer)
    body = Health(version=bench.__version__, bench=svc.cfg.name, transport=svc.transport, clock=svc.cfg.clock,
                  estop=svc.estop.active, active_runs=len(svc.runs.handles),
                  host_overruns=svc.runs.host_overruns())
    return Response(body.model_dump_json(), media_type="application/json")


# --- e-stop ------------------------------------------------------------------------------------
def _estop_state(svc: Service, extra: dict | None = None) -> EStopState:
    doc = {"active": svc.estop.active, "reason": svc.estop.reason, "triggered_at": svc.estop.triggered_at,
           "drives": svc.estop.last_result if svc.estop.active else []}
    doc.update(extra or {})
    return EStopState(**doc)


@router.post("/estop", response_model=EStopState, tags=["safety"], responses={**E.UNAUTHORIZED},
             summary="Torque off on every drive now (any valid key); latched until an admin resets it")
async def estop(request: Request, svc: Service = Depends(service), who: Principal = Depends(principal)):
    # async on purpose: it runs on the event loop itself, never waiting for a worker thread
    # of the thread pool that the other (blocking) handlers share.  It blocks the loop until
    # every run process has answered (milliseconds; at most api.safety.REMOTE_WAIT, then the
    # silent ones are killed): nothing else should be served before the bench is stopped.
    result = svc.estop.trigger(f"e-stop by {who.name} ({who.role})")
    return _estop_state(svc, {"stop_latency_ms": result["stop_latency_ms"], "drives": result["drives"]})


@router.get("/estop", response_model=EStopState, tags=["safety"], responses={**E.UNAUTHORIZED, **E.FORBIDDEN})
def estop_state(svc: Service = Depends(service), _=Depends(observer)):
    return _estop_state(svc)


@router.post("/estop/reset", response_model=EStopState, tags=["safety"],
             responses={**E.UNAUTHORIZED, **E.FORBIDDEN, **E.CONFLICT},
             summary="Clear the e-stop latch (admin) once every stopped run has ended")
def estop_reset(svc: Service = Depends(service), _=Depends(admin)):
    stopping = [h.run_id for h in svc.runs.active() if h.estopped is not None]
    if stopping:
        raise Conflict(f"runs still stopping: {', '.join(stopping)}; retry when they have ended")
    svc.estop.reset()
    return _estop_state(svc)


# --- keys ----------------------------------------------------------------------------------------
@router.post("/keys", status_code=201, response_model=KeyCreated, tags=["keys"],
             responses={**E.AUTH, 409: E._doc("the key cap is reached: revoke unused keys first")},
             summary="Create an API key (admin); the key is in this answer only")
def create_key(body: KeyCreate, svc: Service = Depends(service), _=Depends(admin)):
    key, info = svc.keys.create(body.role, body.name)
    return KeyCreated(key=key, **info)


@router.get("/keys", response_model=KeyList, tags=["keys"], responses={**E.UNAUTHORIZED, **E.FORBIDDEN})
def list_keys(svc: Service = Depends(service), _=Depends(admin)):
    return KeyList(keys=[KeyInfo(**k) for k in svc.keys.list()])


@router.delete("/keys/{key_id}", status_code=204, response_class=Response, tags=["keys"],
               responses={**E.UNAUTHORIZED, **E.FORBIDDEN, **E.NOT_FOUND}, summary="Revoke a key (admin)")
def revoke_key(key_id: str, svc: Service = Depends(service), _=Depends(admin)):
    if not svc.keys.revoke(key_id):
        raise NotFound(f"no key {key_id[:40]!r}")
    return Response(status_code=204)


# --- analysis of an uploaded record ------------------------------------------------------------
@router.get("/effects", response_model=EffectList, tags=["analysis"], responses={**E.UNAUTHORIZED, **E.FORBIDDEN},
            summary="The effect library: what POST /analyze?add= takes")
def effects(_=Depends(observer)):
    from bench.effects import EFFECTS
    from bench.map_fit import CONTENDERS
    return EffectList(effects=[EffectInfo(name=n, summary=e.summary, screened=e.auto, on_maps=n in CONTENDERS)
                               for n, e in EFFECTS.items()])


_BINARY = {"type": "string", "format": "binary"}
_UPLOAD_DOC = {"requestBody": {"required": True, "content": {
    "text/csv": {"schema": {"type": "string", "minLength": 1}},
    "application/vnd.apache.parquet": {"schema": _BINARY},
    "application/x-matlab-data": {"schema": _BINARY},
    "application/octet-stream": {"schema": _BINARY},
    "multipart/form-data": {"schema": {"type": "object", "required": ["file"],
                                       "properties": {"file": _BINARY}}}}}}
# content types taken as a record body; the format itself is told by its magic bytes
_TEXT = ("text/csv", "text/plain", "application/csv", "text/tab-separated-values")
_BINARIES = {"application/vnd.apache.parquet": ".parquet", "application/x-parquet": ".parquet",
             "application/x-matlab-data": ".mat", "application/x-mat": ".mat",
             "application/octet-stream": "",
             # a compressed or zipped record of any format: its magic bytes say which (bench.containers)
             "application/gzip": "", "application/x-gzip": "", "application/zip": "",
             "application/x-bzip2": "", "application/x-xz": "", "application/zstd": ""}


@router.post("/analyze", response_model=dict[str, Any], tags=["analysis"], openapi_extra=_UPLOAD_DOC,
             responses={**E.AUTH, 413: E._doc("record too large"), 415: E._doc("not a record body")},
             summary="Identify and diagnose an uploaded record (CSV, Parquet or MATLAB .mat, "
                     "compressed or zipped as logs are kept); the report JSON")
async def analyze(request: Request, inertia: Optional[str] = Query(None, max_length=40,
                                                  description="M_jj [SI]; 0: the torque column is the friction; "
                                                              "estimate: read it off the record"),
                  columns: Optional[str] = Query(None, max_length=400, description="t=NAME,tau=NAME,q=NAME[,qd=NAME]; NAME@TIME: a column with a time column of its own"),
                  joint: Optional[str] = Query(None, max_length=60, pattern=r"^[A-Za-z0-9_.\-]+$",
                                               description="a log of several joints: this joint's number or name as the column names hold it"),
                  joint_type: Optional[str] = Query(None, pattern="^(revolute|prismatic)$"),
                  time_unit: Optional[str] = Query(None, pattern="^(s|ms|us|ns)$", description="numeric time's unit (default s)"),
                  window: Optional[str] = Query(None, max_length=60, description="START:END seconds from the first sample"),
                  sample_rate: Optional[float] = Query(None, gt=0, le=1e7, description="the rows' rate [Hz], for a file without a time column"),
                  position_unit: Optional[str] = Query(None, max_length=20, description="rad, deg, rev; m, mm, um"),
                  torque_unit: Optional[str] = Query(None, max_length=20, description="N*m, mN*m, kN*m, N*mm; N, mN, kN"),
                  torque_hold: Optional[str] = Query(None, pattern="^(zoh|sample|auto)$"),
                  encoder: Optional[str] = Query(None, pattern="^(motor|load)$",
                                                 description="a geared joint's encoder side (default motor)"),
                  add: Optional[str] = Query(None, max_length=200, description="effects to add, comma-separated"),
                  diagnose: bool = Query(True, description="diagnose what the LuGre model misses"),
                  plots: bool = Query(False, description="add the report's plots as PNG data: URIs (`plots`)"),
                  residuals: bool = Query(False, description="add `bench analyze --residuals`'s CSV as text "
                                                             "(`residuals_csv`): t, measured, baseline, final, "
                                                             "held_out at the file's own timestamps"),
                  svc: Service = Depends(service), _=Depends(operator)):
    # the core speaks bench analyze's options; a poster of files is told the query parameters
    from api.wording import in_api_words, report_in_api_words
    try:
        doc = await _analyze(request, svc, inertia, columns, joint, joint_type, time_unit, window,
                             sample_rate, position_unit, torque_unit, torque_hold, add, diagnose, plots, encoder,
                             residuals)
    except InputError as e:
        raise type(e)(in_api_words(str(e))) from None
    if isinstance(doc, Response):
        return doc
    # megabytes of base64 and of rows: not words to translate
    kept = {k: doc.pop(k) for k in ("plots", "residuals_csv") if k in doc}
    return {**report_in_api_words(doc), **kept}


async def _analyze(request: Request, svc: Service, inertia, columns, joint, joint_type, time_unit, window,
                   sample_rate, position_unit, torque_unit, torque_hold, add, diagnose, plots, encoder,
                   residuals=False):
    name, raw = await _upload(request)
    from bench.readers import parse_columns, parse_window
    from bench.records import inertia_setting
    inertia = inertia_setting(inertia)
    parse_columns(columns)   # a bad mapping or window is told before the upload is queued
    parse_window(window)
    options = {"columns": columns, "joint_type": joint_type, "position_unit": position_unit,
               "torque_unit": torque_unit, "inertia": inertia, "torque_hold": torque_hold,
               "time_unit": time_unit, "window": window, "sample_rate": sample_rate, "joint": joint,
               "encoder": encoder}
    effects = [e.strip() for e in add.split(",") if e.strip()] if add is not None else None
    if svc.analysis_pool is None:
        from api.analysis_worker import AnalysisWorker
        svc.analysis_pool = AnalysisWorker()
    worker = svc.analysis_pool
    waiting = None
    try:
        job, fut = worker.submit(raw, name, options, effects, diagnose, plots, residuals)
        waiting = asyncio.wrap_future(fut)
        while True:
            done, _ = await asyncio.wait({waiting}, timeout=POLL_DISCONNECT)
            if done:
                return waiting.result()
            if await request.is_disconnected():      # its client gave up: free the worker
                worker.abandon(job, fut)
                waiting.cancel()       # its Stopped is never read: not logged as unretrieved
                return Response(status_code=499)     # nobody reads it ("client closed request")
    except BrokenProcessPool:   # the analysis process died (memory?): a new one next time
        svc.analysis_pool = None
        raise HTTPException(503, "the analysis process died; retry") from None
    except asyncio.CancelledError:                   # the server is stopping
        if waiting is not None:
            worker.abandon(job, fut)
            waiting.cancel()
        raise


async def _upload(request: Request) -> tuple[str, bytes]:
    ctype = (request.headers.get("content-type") or "").lower()
    length = request.headers.get("content-length")
    if length is not None and length.isdigit() and int(length) > MAX_UPLOAD:
        raise HTTPException(413, f"record too large: {int(length)} bytes (limit {MAX_UPLOAD})")
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > MAX_UPLOAD:
            raise HTTPException(413, f"record too large (limit {MAX_UPLOAD} bytes)")
    base = ctype.split(";")[0].strip()
    if base == "multipart/form-data":
        name, raw = _multipart_file(bytes(body), request.headers["content-type"])
    elif base in _TEXT or not base:
        name, raw = "upload.csv", bytes(body)
    elif base in _BINARIES:
        name, raw = "upload" + _BINARIES[base], bytes(body)
    else:
        raise HTTPException(415, f"send the record as text/csv, application/vnd.apache.parquet, "
                                 f"application/x-matlab-data, application/gzip, application/zip, "
                                 f"application/octet-stream or multipart/form-data "
                                 f"(field 'file'), not {ctype[:60]!r}")
    if not raw.strip():
        raise InputError(f"{name}: empty record")
    return name, raw


def _multipart_file(body: bytes, content_type: str) -> tuple[str, bytes]:
    """The 'file' part (or the only part) of a multipart/form-data body, by the stdlib's MIME
    parser (no extra dependency)."""
    msg = email.parser.BytesParser(policy=email.policy.HTTP).parsebytes(
        b"Content-Type: " + content_type.encode("latin-1", "replace") + b"\r\n\r\n" + body)
    if not msg.is_multipart():
        raise InputError("multipart body without parts (boundary missing?)")
    parts = [p for p in msg.iter_parts() if p.get_param("name", header="content-disposition") is not None]
    chosen = next((p for p in parts if p.get_param("name", header="content-disposition") == "file"),
                  parts[0] if len(parts) == 1 else None)
    if chosen is None:
        raise InputError("multipart body: no field 'file'")
    payload = chosen.get_payload(decode=True) or b""
    name = chosen.get_filename() or "upload.csv"
    return str(name)[:200], payload
