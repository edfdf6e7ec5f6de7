"""Request and response bodies of the REST service (they are the OpenAPI schema)."""
from __future__ import annotations

from typing import Annotated, Any, Literal, Optional

from pydantic import BaseModel, ConfigDict, Field, StrictBool

Procedure = Literal["identify", "tracking", "calibrate"]
RunState = Literal["queued", "running", "succeeded", "failed", "cancelled", "interrupted"]
Role = Literal["observer", "operator", "admin"]
JointId = Annotated[str, Field(min_length=1, max_length=64)]


class Strict(BaseModel):
    # request bodies: unknown fields refused, NaN and infinities refused as such ("Input should
    # be a finite number", not a bound's message), booleans only as JSON true/false (StrictBool)
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


# --- errors ----------------------------------------------------------------------------------
class FieldError(BaseModel):
    field: str
    message: str


class ErrorBody(BaseModel):
    detail: str = Field(description="one line saying what is wrong")
    errors: Optional[list[FieldError]] = None


# --- service / joints ------------------------------------------------------------------------
class Health(BaseModel):
    status: Literal["ok"] = "ok"
    version: str
    bench: str
    transport: str
    clock: str
    estop: bool
    active_runs: int
    host_overruns: Optional[int] = Field(None, description="control periods the runs' host pacers missed since "
                                                           "the server started: ended runs plus the live counts "
                                                           "of active ones (realtime clock; 0 in lock-step)")


class Limits(BaseModel):
    position: list[float] = Field(description="[lo, hi] in rad or m")
    velocity: float
    torque: float


class CompensationState(BaseModel):
    joint_id: str
    enabled: bool
    model_id: Optional[str] = None
    updated: Optional[float] = None


class ModelInfo(BaseModel):
    id: str
    run_id: Optional[str] = None
    created: float
    parameters: dict[str, float]


class DriveInfo(BaseModel):
    state: Optional[str] = Field(None, description="drive state: enabled, disabled, quick_stop, fault")
    t: Optional[float] = None
    position: Optional[float] = None
    velocity: Optional[float] = None
    torque: Optional[float] = None
    open: bool = Field(False, description="a run has the drive open now")


class JointSummary(BaseModel):
    id: str
    transport: str
    joint_type: str
    state: Literal["idle", "busy", "estopped"]
    run_id: Optional[str] = Field(None, description="the run holding the joint")


class JointDetail(JointSummary):
    limits: Limits
    gravity: list[float]
    inertia: Any = Field(description="declared M_jj: a number or a table {joint, q, value}")
    compensation: CompensationState
    model: Optional[ModelInfo] = Field(None, description="the model compensation uses (or the newest)")
    drive: DriveInfo


class JointList(BaseModel):
    bench: str
    joints: list[JointSummary]


class CompensationUpdate(Strict):
    enabled: StrictBool
    model: Optional[str] = Field(None, max_length=128,
                                 description="model id (from a run's result); default: keep the current one, "
                                             "or the joint's newest model")


# --- runs ------------------------------------------------------------------------------------
class RunOptions(Strict):
    """Everything optional; defaults are the procedures' own.  Shorter settings make test
    runs short."""
    seed: int = Field(0, ge=0, le=2**31 - 1, description="seed of the virtual drives' noise")
    plots: StrictBool = Field(True, description="write PNG plots and the HTML report")
    search_max_trials: Optional[int] = Field(None, ge=1, le=30, description="excitation search: most trials")
    search_cycles: Optional[float] = Field(None, ge=1.0, le=10.0, description="excitation search: cycles per trial")
    tracking_period: Optional[float] = Field(None, ge=0.5, le=60.0, description="tracking: reference period [s]")
    tracking_cycles: Optional[float] = Field(None, ge=0.5, le=20.0, description="tracking: cycles per variant")
    compensation: Literal["current", "off", "on", "both"] = Field(
        "current", description="tracking: the joint's switch (current), forced off/on, or both in one run")
    model: Optional[str] = Field(None, max_length=128, description="tracking: model id to compensate with")


class RunRequest(Strict):
    procedure: Procedure
    joints: Optional[list[JointId]] = Field(
        None, max_length=16, json_schema_extra={"uniqueItems": True}, description="joint ids; default every joint of the bench (a calibration "
                                         "always holds every joint: its rig cycles them all)")
    options: RunOptions = Field(default_factory=RunOptions)

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, json_schema_extra={
        "examples": [{"procedure": "identify", "joints": ["j1"], "options": {"search_max_trials": 8}}]})


class RunCreated(BaseModel):
    id: str
    procedure: str
    state: RunState
    joints: list[str]
    location: str


class RunInfo(BaseModel):
    id: str
    procedure: str = Field(description="identify | tracking | calibrate (child runs: their kind)")
    kind: str
    state: RunState
    progress: float = Field(ge=0.0, le=1.0)
    joints: list[str]
    parent_id: Optional[str] = None
    created: float
    started: Optional[float] = None
    ended: Optional[float] = None
    error: Optional[str] = None
    options: dict[str, Any] = {}
    result: Optional[dict[str, Any]] = Field(
        None, description="when done: identified parameters and diagnosis, tracking errors, overruns")


class RunList(BaseModel):
    runs: list[RunInfo]


# --- e-stop, keys ----------------------------------------------------------------------------
class DriveStop(BaseModel):
    joint: str
    run_id: Optional[str] = None
    state: Optional[str] = None
    torque_off: Optional[bool] = None
    error: Optional[str] = None


class EStopState(BaseModel):
    active: bool
    reason: str = ""
    triggered_at: Optional[float] = None
    stop_latency_ms: Optional[float] = Field(None, description="latch to every drive stopped, in the handler")
    drives: list[DriveStop] = []


class KeyCreate(Strict):
    role: Role
    name: str = Field("", max_length=64)


class KeyInfo(BaseModel):
    id: str
    name: str
    role: Role
    created: float


class KeyCreated(KeyInfo):
    key: str = Field(description="shown once; only its hash is stored")


class KeyList(BaseModel):
    keys: list[KeyInfo]


class EffectInfo(BaseModel):
    name: str
    summary: str
    screened: bool      # tried by every diagnosis; False: only when asked (``add``)
    on_maps: bool       # a friction-velocity map can show it


class EffectList(BaseModel):
    effects: list[EffectInfo]
