"""Every error is a one-line JSON ``{"detail": ...}`` with a 4xx status; never a traceback.

Mapping: body/parameter validation -> 422 naming the field; ``NotFound`` -> 404;
``Conflict`` -> 409; ``InputError`` (bad record, bad option, unknown model) -> 422; any other
``BenchError`` -> 400.  Anything else is a bug: it is logged with its traceback and answered
500 with a clean JSON body (the fuzz test exists to find those, and they get fixed).
"""
from __future__ import annotations

import logging

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from api.auth import TooManyKeys
from api.models import ErrorBody
from api.runs import Conflict, NotFound
from bench.errors import BenchError, InputError

log = logging.getLogger("api")


def _doc(description: str) -> dict:
    return {"model": ErrorBody, "description": description}


def _json_doc(description: str) -> dict:
    """An error documented as JSON on a route whose own answer is not JSON (HTML, CSV, SSE):
    FastAPI would otherwise document the error in the route's media type."""
    return {"description": description,
            "content": {"application/json": {"schema": {"$ref": "#/components/schemas/ErrorBody"}}}}


def non_json(*codes: int) -> dict:
    texts = {401: "no or unknown API key", 413: "request body over the cap", 429: "too many requests without a valid API key", 403: "the key's role does not allow this",
             404: "unknown run or joint", 409: "not available yet: the run has not ended / the trace is "
             "being written", 422: "invalid request: the message names the field"}
    return {c: _json_doc(texts[c]) for c in codes}


UNAUTHORIZED = {401: _doc("no or unknown API key"),
                413: _doc("request body over the endpoint's cap (refused before it is read)"),
                429: _doc("too many requests without a valid API key from this address; see Retry-After")}
FORBIDDEN = {403: _doc("the key's role does not allow this")}
NOT_FOUND = {404: _doc("unknown run or joint")}
CONFLICT = {409: _doc("a joint is busy or the e-stop is active")}
INVALID = {422: _doc("invalid request: the message names the field")}
AUTH = {**UNAUTHORIZED, **FORBIDDEN, **INVALID}


def _field(loc) -> str:
    parts = [str(p) for p in loc]
    return ".".join(parts) if parts else "request"


def install(app: FastAPI) -> None:
    @app.exception_handler(RequestValidationError)
    async def validation(request: Request, exc: RequestValidationError):
        errors = []
        for e in exc.errors():
            msg = str(e.get("msg", "invalid"))
            errors.append({"field": _field(e.get("loc", ())), "message": msg})
        first = errors[0] if errors else {"field": "request", "message": "invalid"}
        more = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
        return JSONResponse({"detail": f"{first['field']}: {first['message']}{more}", "errors": errors},
                            status_code=422)

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException):
        headers = dict(exc.headers or {})
        if exc.status_code == 400 and exc.detail == "There was an error parsing the body":
            # FastAPI's answer to a body it cannot even decode; malformed JSON is 422 already
            return JSONResponse({"detail": "body: not valid JSON text (UTF-8)"}, status_code=422)
        if exc.status_code == 405:
            # Starlette names only the first route matching the path; a path served by
            # several routes (GET and POST /estop) allows the methods of all of them
            allowed = set()
            for route in _routes(request.app.router.routes):
                if getattr(route, "methods", None) and hasattr(route, "path_regex") \
                        and route.path_regex.match(request.scope["path"]):
                    allowed |= set(route.methods)
            if allowed:
                headers["Allow"] = ", ".join(sorted(allowed))
        return JSONResponse({"detail": str(exc.detail)}, status_code=exc.status_code, headers=headers or None)

    @app.exception_handler(BenchError)
    async def bench_error(request: Request, exc: BenchError):
        status = 404 if isinstance(exc, NotFound) else 409 if isinstance(exc, (Conflict, TooManyKeys)) \
            else 422 if isinstance(exc, InputError) else 400
        return JSONResponse({"detail": _one_line(exc)}, status_code=status)

    @app.exception_handler(Exception)
    async def unexpected(request: Request, exc: Exception):
        log.error("unexpected error on %s %s", request.method, request.url.path, exc_info=exc)
        return JSONResponse({"detail": f"internal error ({exc.__class__.__name__}); it was logged"},
                            status_code=500)


def _routes(routes):
    """Every route, through the routers FastAPI keeps as included sub-routers."""
    for r in routes:
        sub = getattr(r, "original_router", None)
        if sub is not None:
            yield from _routes(sub.routes)
        else:
            yield r


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split()) or exc.__class__.__name__
