"""/joints: configuration, state, model and the compensation switch."""
from __future__ import annotations

from fastapi import APIRouter, Depends, Response

from api import errors as E
from api.deps import Service, observer, operator, service
from api.models import (CompensationState, CompensationUpdate, DriveInfo, JointDetail, JointList,
                        JointSummary, Limits, ModelInfo)
from api.runs import NotFound
from bench.compensation import set_compensation
from bench.errors import InputError

router = APIRouter(tags=["joints"], responses={**E.AUTH})


def _joint(svc: Service, joint_id: str) -> dict:
    if joint_id not in svc.cfg.ids:
        raise NotFound(f"bench {svc.cfg.name!r} has no joint {joint_id[:64]!r}; joints: {', '.join(svc.cfg.ids)}")
    return svc.cfg.joint(joint_id)


def _summary(svc: Service, j: dict) -> dict:
    run_id = svc.runs.busy.get(j["id"])
    state = "estopped" if svc.estop.active else "busy" if run_id else "idle"
    return {"id": j["id"], "transport": j["transport"], "joint_type": j.get("joint_type", "revolute"),
            "state": state, "run_id": run_id}


def _drive(svc: Service, joint_id: str) -> DriveInfo:
    run_id = svc.runs.busy.get(joint_id)
    h = svc.runs.handles.get(run_id) if run_id else None
    live = h.drive_sample(joint_id) if h is not None else None      # relayed by the run's process
    if live is not None:
        return DriveInfo(**live, open=True)
    last = svc.runs.last_drive.get(joint_id)
    return DriveInfo(**last, open=False) if last else DriveInfo(open=False)


@router.get("/joints", response_model=JointList, summary="The bench's joints and whether they are busy")
def list_joints(svc: Service = Depends(service), _=Depends(observer)):
    return JointList(bench=svc.cfg.name, joints=[JointSummary(**_summary(svc, j)) for j in svc.cfg.joints])


@router.get("/joints/{joint_id}", response_model=JointDetail, responses={**E.NOT_FOUND},
            summary="A joint: state, limits, current model, compensation, last drive sample")
async def read_joint(joint_id: str, svc: Service = Depends(service), _=Depends(observer)):
    # Polled for every joint by every page on the bench view.  Async, and the stored part
    # (compensation, model) from api.cache while the store is unchanged: no worker thread,
    # no SQLite read, no second validation of the answer in the common case.
    j = _joint(svc, joint_id)
    comp, model = await svc.joint_cache.stored(joint_id)
    body = JointDetail(**_summary(svc, j),
                       limits=Limits(position=list(j["position_limits"]), velocity=j["velocity_limit"],
                                     torque=j["torque_limit"]),
                       gravity=list(j["gravity"]), inertia=j["inertia"],
                       compensation=CompensationState(**comp),
                       model=ModelInfo(**model) if model is not None else None,
                       drive=_drive(svc, joint_id))
    return Response(body.model_dump_json(), media_type="application/json")


@router.put("/joints/{joint_id}/compensation", response_model=CompensationState, responses={**E.NOT_FOUND},
            summary="Switch friction compensation on/off, optionally choosing the model")
def put_compensation(joint_id: str, body: CompensationUpdate, svc: Service = Depends(service),
                     _=Depends(operator)):
    _joint(svc, joint_id)
    if body.model is not None:
        try:
            svc.store.get_model(body.model)
        except InputError:
            raise NotFound(f"no model {body.model!r}") from None
    return CompensationState(**set_compensation(svc.store, joint_id, body.enabled, body.model))
