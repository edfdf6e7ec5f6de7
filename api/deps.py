"""What every route needs: the service state and the caller's key (``Authorization: Bearer``)."""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path

from fastapi import Depends, HTTPException, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from api.auth import KeyStore, Principal
from api.cache import JointCache, StoreVersion
from api.limits import AuthFailures
from api.runs import RunManager
from api.safety import EStop
from bench.store import Store
from procedures.config import BenchConfig


@dataclass
class Service:
    cfg: BenchConfig
    bench_spec: str
    transport: str
    data_dir: Path
    store: Store
    keys: KeyStore
    estop: EStop
    runs: RunManager
    analysis_pool: object = None     # api.analysis_worker.AnalysisWorker, made at the first POST /analyze
    run_cache: OrderedDict = field(default_factory=OrderedDict)   # GET /runs/{id} answers (routes_runs)
    feeds: dict = field(default_factory=dict)     # run id -> its event streams' api.feed.RunFeed
    auth_failures: AuthFailures = field(default_factory=AuthFailures)   # 429 past its budget (api.limits)
    version: StoreVersion = None     # whether the store changed (api.cache); from the store
    joint_cache: JointCache = None   # GET /joints/{id}'s stored part (api.cache)

    def __post_init__(self):
        self.version = self.version or StoreVersion(self.store.path)
        self.joint_cache = self.joint_cache or JointCache(self.store, self.version)


# The dependencies are async on purpose: FastAPI runs a sync dependency in the thread pool,
# and three thread hops per request cost more CPU (and GIL) than the checks themselves.
async def service(request: Request) -> Service:
    return request.app.state.service


_bearer = HTTPBearer(auto_error=False, description="API key: observer, operator or admin")


async def principal(request: Request, creds: HTTPAuthorizationCredentials | None = Depends(_bearer),
                    svc: Service = Depends(service)) -> Principal:
    p = svc.keys.authenticate(creds.credentials) if creds is not None and creds.credentials else None
    if p is not None:
        return p
    wait = svc.auth_failures.charge(request.client.host if request.client else "?")
    if wait is not None:     # bounded: a client without a valid key cannot keep the server busy
        raise HTTPException(429, "too many requests without a valid API key; retry later",
                            headers={"Retry-After": str(max(1, round(wait)))})
    if creds is None or not creds.credentials:
        raise HTTPException(401, "missing API key: send 'Authorization: Bearer <key>'",
                            headers={"WWW-Authenticate": "Bearer"})
    raise HTTPException(401, "invalid API key", headers={"WWW-Authenticate": "Bearer"})


def require(role: str):
    async def check(p: Principal = Depends(principal)) -> Principal:
        if not p.allows(role):
            raise HTTPException(403, f"this needs the {role} role; your key {p.name!r} is {p.role}")
        return p
    return check


observer = require("observer")
operator = require("operator")
admin = require("admin")
