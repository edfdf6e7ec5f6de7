"""The FastAPI application factory.

    app = create_app(ServiceConfig(bench="macro4", data_dir="bench-data"))

Startup opens the run store (SQLite WAL in the data directory), marks runs a dead server
left behind as interrupted, loads the API keys (generating the first admin key), and the
bench configuration.  Shutdown cancels active runs (controlled ramp-down) and waits for them.
"""
from __future__ import annotations

import logging
import os
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path

from fastapi import FastAPI

import bench
from api import errors
from api.auth import ENV_KEY, KeyStore
from api.deps import Service
from api.runs import RunManager
from api.safety import EStop
from bench.errors import InputError
from bench.store import Store
from procedures.config import load_bench

log = logging.getLogger("api")
TRANSPORTS = ("virtual", "simulated", "hardware")  # hardware: the drives the bench file names


@dataclass
class ServiceConfig:
    bench: str = "macro4"
    data_dir: str | Path = "bench-data"
    transport: str = "virtual"       # emulated CANopen/serial drives, or in-process simulated plugs
    api_key: str | None = None       # accepted as an admin key (default: $BENCH_API_KEY)
    shutdown_timeout: float = 20.0


def build_service(conf: ServiceConfig) -> tuple[Service, Path | None]:
    if conf.transport not in TRANSPORTS:
        raise InputError(f"transport must be one of {', '.join(TRANSPORTS)}, got {conf.transport!r}")
    cfg = load_bench(conf.bench)
    data = Path(conf.data_dir)
    try:
        store = Store(data)
    except OSError as e:
        raise InputError(f"{data}: cannot open the run store ({e.strerror or e})") from None
    keys = KeyStore(data, env_key=conf.api_key if conf.api_key is not None else os.environ.get(ENV_KEY) or None)
    admin_file = keys.ensure_admin()
    estop = EStop()
    runs = RunManager(store, str(conf.bench), cfg, conf.transport, estop)
    return Service(cfg=cfg, bench_spec=str(conf.bench), transport=conf.transport, data_dir=data, store=store,
                   keys=keys, estop=estop, runs=runs), admin_file


def create_app(conf: ServiceConfig | None = None, service: Service | None = None) -> FastAPI:
    conf = conf or ServiceConfig()
    svc = service if service is not None else build_service(conf)[0]

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        app.state.closing = False
        yield
        app.state.closing = True          # SSE streams end at their next poll
        svc.runs.shutdown(conf.shutdown_timeout)
        if svc.analysis_pool is not None:
            svc.analysis_pool.shutdown(wait=False, cancel_futures=True)

    app = FastAPI(title="friction-bench", version=bench.__version__, lifespan=lifespan,
                  description="Identify and compensate LuGre friction in robot joints: start identification, "
                              "tracking and calibration runs, watch them live, switch compensation per joint. "
                              "Every endpoint but /health needs `Authorization: Bearer <key>` "
                              "(roles: observer < operator < admin; any key may e-stop).")
    app.state.service = svc
    app.state.closing = False
    errors.install(app)
    from api import routes_joints, routes_runs, routes_service
    app.include_router(routes_service.router)
    app.include_router(routes_joints.router)
    app.include_router(routes_runs.router)
    return app
