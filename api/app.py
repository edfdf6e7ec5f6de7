"""The FastAPI application factory.

    app = create_app(ServiceConfig(bench="macro4", data_dir="bench-data"))

Startup opens the run store (SQLite WAL in the data directory), marks runs a dead server
left behind as interrupted, loads the API keys (generating the first admin key), and the
bench configuration, and starts the forkserver that runs' control processes come from.
Shutdown cancels active runs (controlled ramp-down), waits for them, then kills what is left.
"""
from __future__ import annotations

import gc
import logging
import os
from contextlib import asynccontextmanager
from dataclasses import dataclass
from pathlib import Path

from fastapi import FastAPI

import bench
from api import cpus, errors
from api.auth import ENV_KEY, KeyStore
from api.deps import Service
from api.runs import RunManager
from api.safety import EStop
from bench.errors import InputError
from bench.store import Store
from drivers.realtime import check_priority
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
    # this process (the server) on the last CPU, run control processes on the others
    # (api.cpus); `bench serve` does, a server embedded in another program (tests) does not
    pin_cpus: bool = False
    # run control processes (and the emulated drives they start) at this SCHED_FIFO priority;
    # 0: normal scheduling (drivers.realtime)
    rt_priority: int = 0


def build_service(conf: ServiceConfig) -> tuple[Service, Path | None]:
    if conf.transport not in TRANSPORTS:
        raise InputError(f"transport must be one of {', '.join(TRANSPORTS)}, got {conf.transport!r}")
    check_priority(conf.rt_priority, "rt_priority")
    cfg = load_bench(conf.bench)
    data = Path(conf.data_dir)
    try:
        store = Store(data)
    except OSError as e:
        raise InputError(f"{data}: cannot open the run store ({e.strerror or e})") from None
    keys = KeyStore(data, env_key=conf.api_key if conf.api_key is not None else os.environ.get(ENV_KEY) or None)
    admin_file = keys.ensure_admin()
    estop = EStop(store=store)         # a latch from before a crash or restart is restored
    placement = cpus.split() if conf.pin_cpus else None
    if placement is not None:
        cpus.pin(placement[0])
    runs = RunManager(store, str(conf.bench), cfg, conf.transport, estop,
                      control_cpus=placement[1] if placement is not None else None,
                      rt_priority=conf.rt_priority)
    return Service(cfg=cfg, bench_spec=str(conf.bench), transport=conf.transport, data_dir=data, store=store,
                   keys=keys, estop=estop, runs=runs), admin_file


def create_app(conf: ServiceConfig | None = None, service: Service | None = None) -> FastAPI:
    conf = conf or ServiceConfig()
    svc = service if service is not None else build_service(conf)[0]

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        app.state.closing = False
        # the imported modules (numpy, scipy, numba, FastAPI: ~200k objects) never become
        # garbage: frozen once, a full collection triggered by request allocations does not
        # rescan them, which would stall every request in flight for ~100 ms
        gc.collect()
        gc.freeze()
        yield
        app.state.closing = True          # SSE streams end at their next poll
        svc.runs.shutdown(conf.shutdown_timeout)
        if svc.analysis_pool is not None:
            svc.analysis_pool.shutdown()

    app = FastAPI(title="friction-bench", version=bench.__version__, lifespan=lifespan,
                  description="Identify and compensate LuGre friction in robot joints: start identification, "
                              "tracking and calibration runs, watch them live, switch compensation per joint. "
                              "Every endpoint but /health needs `Authorization: Bearer <key>` "
                              "(roles: observer < operator < admin; any key may e-stop).")
    app.state.service = svc
    app.state.closing = False
    errors.install(app)
    from api.limits import BodyLimit
    app.add_middleware(BodyLimit)      # body cap before the body is read and before any auth
    from api import routes_joints, routes_page, routes_runs, routes_service
    app.include_router(routes_service.router)
    app.include_router(routes_joints.router)
    app.include_router(routes_runs.router)
    routes_page.mount(app)          # the technician's page at / (api/static)
    return app
