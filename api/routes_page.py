"""The technician's page: ``GET /`` and its static files (``api/static``), plus ``GET /whoami``
so that the page can show the caller's role.

The page is plain HTML/JS/CSS shipped inside the package (no CDN, no build step) and talks
only to the REST API with the key the technician typed (kept in the browser's
sessionStorage, sent as ``Authorization: Bearer``).  The live stream is read with
``fetch()`` and a stream reader, which sends that header, so no key ever appears in a URL.
The page and its files need no key: they hold no data.
"""
from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, Depends
from fastapi.responses import FileResponse
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel

from api import errors as E
from api.auth import Principal
from api.deps import principal

STATIC = Path(__file__).with_name("static")
router = APIRouter()


class WhoAmI(BaseModel):
    name: str
    role: str


@router.get("/", include_in_schema=False)
def page():
    # no-cache: a technician reloading after an upgrade gets the page that matches the API
    return FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-cache"})


@router.get("/whoami", response_model=WhoAmI, tags=["service"], responses={**E.UNAUTHORIZED},
            summary="The caller's key: its name and role (any valid key)")
async def whoami(who: Principal = Depends(principal)):
    return WhoAmI(name=who.name, role=who.role)


def mount(app) -> None:
    app.include_router(router)
    app.mount("/static", StaticFiles(directory=STATIC), name="static")
