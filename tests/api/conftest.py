"""A real service for the API tests: uvicorn on 127.0.0.1 (free port) in a thread of this
process, a real SQLite store in a temporary directory, and the macro4 bench behind it on
emulated drives reached over the real CANopen / ODrive-serial stacks (VirtualBench +
drivers.registry.open_drive).  Clients are real httpx clients with timeouts.

One server per session keeps the suite short; each test uses its own joints and waits for
its runs to end, so the order of the tests does not matter.
"""
from __future__ import annotations

import httpx
import pytest
from api_helpers import Live

from api.app import ServiceConfig, build_service, create_app
from api.server import serve_in_thread


@pytest.fixture(scope="session")
def live(tmp_path_factory):
    data = tmp_path_factory.mktemp("api-data")
    conf = ServiceConfig(bench="macro4", data_dir=data, transport="virtual", api_key="", shutdown_timeout=20.0)
    svc, admin_file = build_service(conf)
    admin = admin_file.read_text().strip()
    with serve_in_thread(create_app(conf, svc)) as url:
        with httpx.Client(base_url=url, headers={"Authorization": f"Bearer {admin}"}, timeout=10) as c:
            operator = c.post("/keys", json={"role": "operator", "name": "tech"}).json()["key"]
            observer = c.post("/keys", json={"role": "observer", "name": "viewer"}).json()["key"]
        yield Live(url, svc, admin, operator, observer)
        svc.runs.shutdown(20.0)
    assert not svc.runs.handles, "runs still active after shutdown"


@pytest.fixture
def operator(live):
    with live.client(live.operator) as c:
        yield c


@pytest.fixture
def observer(live):
    with live.client(live.observer) as c:
        yield c


@pytest.fixture
def admin(live):
    with live.client(live.admin) as c:
        yield c
