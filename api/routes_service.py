"""/health, /estop, /keys and /analyze."""
from __future__ import annotations

import asyncio
import email.parser
import email.policy
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Optional

from fastapi import APIRouter, Depends, HTTPException, Query, Request, Response

import bench
from api import errors as E
from api.auth import Principal
from api.deps import Service, admin, observer, operator, principal, service
from api.models import EStopState, Health, KeyCreate, KeyCreated, KeyInfo, KeyList
from api.runs import Conflict, NotFound
from bench.errors import InputError

router = APIRouter()
MAX_UPLOAD = 20 * 1024 * 1024     # bytes: a 1 kHz record of a few hours


@router.get("/health", response_model=Health, tags=["service"], summary="Liveness (no key needed)")
def health(svc: Service = Depends(service)):
    return Health(version=bench.__version__, bench=svc.cfg.name, transport=svc.transport, clock=svc.cfg.clock,
                  estop=svc.estop.active, active_runs=len(svc.runs.handles),
                  host_overruns=svc.runs.host_overruns())


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
@router.post("/keys", status_code=201, response_model=KeyCreated, tags=["keys"], responses={**E.AUTH},
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
_UPLOAD_DOC = {"requestBody": {"required": True, "content": {
    "text/csv": {"schema": {"type": "string", "minLength": 1}},
    "multipart/form-data": {"schema": {"type": "object", "required": ["file"],
                                       "properties": {"file": {"type": "string", "format": "binary"}}}}}}}


@router.post("/analyze", response_model=dict[str, Any], tags=["analysis"], openapi_extra=_UPLOAD_DOC,
             responses={**E.AUTH, 413: E._doc("record too large"), 415: E._doc("not CSV or multipart")},
             summary="Identify and diagnose an uploaded record CSV (t, tau, q[, qd]); the report JSON")
async def analyze(request: Request, inertia: Optional[float] = Query(None, gt=0, le=1e9, description="M_jj"),
                  add: Optional[str] = Query(None, max_length=200, description="effects to add, comma-separated"),
                  diagnose: bool = Query(True, description="diagnose what the LuGre model misses"),
                  svc: Service = Depends(service), _=Depends(operator)):
    name, text = await _upload(request)
    effects = [e.strip() for e in add.split(",") if e.strip()] if add is not None else None
    pool = _pool(svc)
    try:
        fut = pool.submit(analyze_text, text, name, inertia, effects, diagnose)
        return await asyncio.wrap_future(fut)
    except BrokenProcessPool:   # the analysis process died (memory?): a new one next time
        svc.analysis_pool = None
        raise HTTPException(503, "the analysis process died; retry") from None


def _pool(svc: Service) -> ProcessPoolExecutor:
    # a separate process: seconds of numerical work must not take the GIL from control loops
    if svc.analysis_pool is None:
        import multiprocessing
        svc.analysis_pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn"))
    return svc.analysis_pool


def analyze_text(text: str, name: str, inertia, effects, diagnose: bool) -> dict:
    """In the analysis process: parse, identify, diagnose; InputError travels back pickled."""
    import io
    import json

    from bench.analysis import analyze_record
    from bench.records import read_csv
    rec = read_csv(io.StringIO(text), name=name)
    result = analyze_record(rec, inertia=inertia, add=effects, diagnose_effects=diagnose, name=name)
    return json.loads(json.dumps(result.report(), default=float))   # plain JSON types only


async def _upload(request: Request) -> tuple[str, str]:
    ctype = (request.headers.get("content-type") or "").lower()
    length = request.headers.get("content-length")
    if length is not None and length.isdigit() and int(length) > MAX_UPLOAD:
        raise HTTPException(413, f"record too large: {int(length)} bytes (limit {MAX_UPLOAD})")
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > MAX_UPLOAD:
            raise HTTPException(413, f"record too large (limit {MAX_UPLOAD} bytes)")
    if ctype.startswith("multipart/form-data"):
        name, raw = _multipart_file(bytes(body), request.headers["content-type"])
    elif ctype.startswith(("text/csv", "text/plain", "application/csv")) or not ctype:
        name, raw = "upload.csv", bytes(body)
    else:
        raise HTTPException(415, f"send the record as text/csv or multipart/form-data (field 'file'), not {ctype[:60]!r}")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(f"{name}: not UTF-8 text") from None
    if not text.strip():
        raise InputError(f"{name}: empty record")
    return name, text


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
