"""Friction compensation: a LuGre observer driven by the measured velocity.

It runs the shared kernel (``bench.lugre.bristle_step`` and ``stribeck_level``), never a
second friction implementation.  Each control period it returns the model's *mean* friction
over the coming period with the measured velocity held, which is what a torque held for that
period has to cancel:  F = sigma0 zbar + sigma1 (z1 - z0) / h + sigma2 v.

The persistent on/off switch per joint (and which model version) lives in the run store;
``get_compensation`` / ``set_compensation`` are the calls the REST API exposes.
"""
from __future__ import annotations

from bench.lugre import LuGreParams, bristle_step, stribeck_level


class LuGreObserver:
    def __init__(self, params: LuGreParams, dt: float, z0: float = 0.0):
        self.p = params
        self.dt = float(dt)
        self.z = float(z0)

    def reset(self, z0: float = 0.0) -> None:
        self.z = float(z0)

    def update(self, v: float) -> float:
        """Advance the bristle state over one period at velocity ``v``; return the friction
        to feed forward for that period."""
        p = self.p
        s = stribeck_level(float(v), p.Fc, p.Fs, p.alpha, p.delta)
        z0 = self.z
        z1, zbar = bristle_step(z0, float(v), self.dt, s, p.sigma0)
        self.z = z1
        return p.sigma0 * zbar + p.sigma1 * (z1 - z0) / self.dt + p.sigma2 * v


class NoCompensation:
    def reset(self, z0: float = 0.0) -> None:
        pass

    def update(self, v: float) -> float:
        return 0.0


def compensator(params: LuGreParams | None, dt: float):
    return NoCompensation() if params is None else LuGreObserver(params, dt)


def get_compensation(store, joint_id: str) -> dict:
    """{joint_id, enabled, model_id, updated} for a joint (off, no model, if never set)."""
    return store.get_compensation(joint_id)


def set_compensation(store, joint_id: str, enabled: bool, model_run_id: str | None = None) -> dict:
    """Switch compensation on/off for a joint, optionally choosing the model version
    (a model id from ``store.list_models(joint_id)``); returns the new state."""
    return store.set_compensation(joint_id, enabled, model_run_id)


def active_model(store, joint_id: str) -> LuGreParams | None:
    """The model to compensate with now, or None when compensation is off."""
    st = store.get_compensation(joint_id)
    if not st["enabled"] or st["model_id"] is None:
        return None
    return LuGreParams.from_dict(store.get_model(st["model_id"])["params"])
