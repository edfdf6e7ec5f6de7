"""A virtual joint: the physics of one drive axis, with encoder quantisation and torque noise.

``VirtualJoint`` is stateful and advanced a control period at a time by the emulated drives;
``simulate_record`` runs a whole open-loop excitation in one compiled call (``bench simulate``).
Both are deterministic for a seed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from bench import terms
from bench.lugre import LuGreParams
from bench.records import ENCODER_SIDES, Record
from virtual_drives.physics import simulate, simulate_two_mass, substeps_for, two_mass_substeps


@dataclass(frozen=True)
class JointSpec:
    """What a joint *is*.  Units: rad and N·m for revolute joints, m and N for prismatic."""
    name: str
    joint_type: str                       # "revolute" | "prismatic"
    inertia: float                        # true M_jj
    friction: LuGreParams                 # true friction
    position_limits: tuple[float, float]  # workspace
    velocity_limit: float
    torque_limit: float
    encoder_resolution: float             # position per encoder count
    torque_noise: float                   # std of the measured-torque noise
    gravity: tuple[float, float] = (0.0, 0.0)  # true a sin q + b cos q, compensated by the host
    excitation: tuple[float, float] = (1.0, 1.0)  # a good (amplitude, frequency) for a sine test
    description: str = ""
    # geared joints (backlash, a gear spring: bench.terms): the share of ``inertia`` beyond
    # the gear, used when an injected effect does not give its own; and which side the
    # encoder reads ("motor", as on most geared joints, or "load")
    load_fraction: float = 0.5
    encoder: str = "motor"
    gear_ratio: float = 1.0               # 1: a direct drive

    @property
    def position_unit(self) -> str:
        return "rad" if self.joint_type == "revolute" else "m"

    @property
    def torque_unit(self) -> str:
        return "N*m" if self.joint_type == "revolute" else "N"

    def with_(self, **changes) -> "JointSpec":
        return replace(self, **changes)


@dataclass
class JointState:
    t: float = 0.0
    q: float = 0.0
    v: float = 0.0
    z: float = 0.0
    q_load: float = 0.0       # geared joints only: the load beyond the gear
    v_load: float = 0.0
    z_load: float = 0.0       # ... and its bristle state, when it carries friction


@dataclass(frozen=True)
class Gear:
    """The two-mass split of a joint whose ``ev`` has backlash or a gear spring."""
    M_motor: float
    M_load: float
    gap: float                # half the backlash width
    w2: float                 # stiffness / M_load
    c2: float                 # damping / M_load
    n_sub: int

    @classmethod
    def of(cls, spec: "JointSpec", ev: np.ndarray, dt: float) -> "Gear | None":
        if not terms.two_mass(ev):
            return None
        frac = ev[terms.LOAD_FRAC] if ev[terms.LOAD_FRAC] > 0 else spec.load_fraction
        frac = min(max(frac, 0.01), 0.99)
        M_load = frac * spec.inertia
        M_motor = spec.inertia - M_load
        gap, w2, c2 = terms.coupling(ev)
        f = spec.friction
        n_sub = two_mass_substeps(dt, M_motor, M_load, w2, c2, f.sigma0, f.sigma1, f.sigma2,
                                  load_friction=float(ev[terms.LOAD_FRICTION]))
        return cls(M_motor, M_load, gap, w2, c2, n_sub)


class VirtualJoint:
    """One simulated axis.  ``extra`` is a ``bench.terms`` vector of physics beyond LuGre
    (gravity of the spec is added to it unless ``gravity`` is False: the condition records
    leave it out, the host compensating it); ``true_inertia`` overrides the spec's inertia."""

    def __init__(self, spec: JointSpec, dt: float = 1e-3, seed: int = 0,
                 extra: np.ndarray | None = None, q0: float | None = None, gravity: bool = True):
        self.spec = spec
        self.dt = float(dt)
        self.rng = np.random.default_rng(seed)
        self.ev = terms.empty() if extra is None else terms.full(extra)
        if gravity:
            self.ev[terms.GRAV_SIN] += spec.gravity[0]
            self.ev[terms.GRAV_COS] += spec.gravity[1]
        self.p = spec.friction.vector()
        f = spec.friction
        self.n_sub = substeps_for(self.dt, spec.inertia, f.sigma0, f.sigma1, f.sigma2)
        self.gear = Gear.of(spec, self.ev, self.dt)
        lo, hi = spec.position_limits
        start = 0.5 * (lo + hi) if q0 is None else float(q0)
        self.state = JointState(q=start, q_load=start)
        self.applied_torque = 0.0
        self._cmd1 = np.zeros(1)

    def advance(self, tau: float, periods: int = 1) -> JointState:
        """Hold ``tau`` for ``periods`` control periods."""
        s = self.state
        if periods == 1:          # the per-SYNC case: no allocation
            cmd = self._cmd1
            cmd[0] = tau
        else:
            cmd = np.full(int(periods), float(tau))
        g = self.gear
        if g is None:
            _, _, _, q, v, z = simulate(cmd, self.dt, self.n_sub, self.spec.inertia, self.p,
                                        self.ev, s.q, s.v, s.z, s.t)
            self.state = JointState(t=s.t + periods * self.dt, q=q, v=v, z=z, q_load=q, v_load=v)
        else:
            *_, q, v, z, ql, vl, zl = simulate_two_mass(
                cmd, self.dt, g.n_sub, g.M_motor, g.M_load, self.p, self.ev, g.gap, g.w2, g.c2,
                s.q, s.v, s.z, s.q_load, s.v_load, s.t, s.z_load)
            self.state = JointState(t=s.t + periods * self.dt, q=q, v=v, z=z, q_load=ql, v_load=vl,
                                    z_load=zl)
        self.applied_torque = float(tau)
        return self.state

    def measured_position(self) -> float:
        q = self.state.q_load if self.spec.encoder == "load" else self.state.q
        return quantise(q, self.spec.encoder_resolution)

    def measured_velocity(self) -> float:
        return self.state.v_load if self.spec.encoder == "load" else self.state.v

    def measured_torque(self) -> float:
        return self.applied_torque + self.spec.torque_noise * float(self.rng.standard_normal())


def quantise(q, resolution: float):
    if resolution <= 0:
        return q
    return np.round(np.asarray(q) / resolution) * resolution + 0.0 if np.ndim(q) else \
        round(q / resolution) * resolution + 0.0   # + 0.0: no "-0" in a record


def sine_torque(amplitude: float, frequency: float, t: np.ndarray,
                ramp_cycles: float = 0.05) -> np.ndarray:
    """tau_m sin(w t - pi/2) with a smooth amplitude ramp over the first ``ramp_cycles``.

    Starting at the negative peak (phase -pi/2) centres the motion: a sine started at zero
    pushes one way for a whole half cycle and the joint oscillates on one side of its start."""
    w = 2.0 * math.pi * frequency
    env = np.clip(t * frequency / ramp_cycles, 0.0, 1.0) if ramp_cycles > 0 else np.ones_like(t)
    env = env * env * (3.0 - 2.0 * env)  # smoothstep
    return amplitude * env * np.sin(w * t - 0.5 * math.pi)


def lagged(t: np.ndarray, command: np.ndarray, lag: float) -> np.ndarray:
    """The held command as a joint feels it ``lag`` seconds late (zero before the start)."""
    return np.interp(t - lag, t, command, left=0.0) if lag > 0 else command


@dataclass
class Simulation:
    """What a simulated run knows and a measured one never does."""
    record: Record
    true_q: np.ndarray
    true_v: np.ndarray
    true_friction_params: LuGreParams
    extra: np.ndarray = field(default_factory=terms.empty)


def simulate_record(spec: JointSpec, amplitude: float, frequency: float, duration: float,
                    dt: float = 1e-3, seed: int = 0, extra: np.ndarray | None = None,
                    declared_inertia: float | None = None, torque_noise: float | None = None,
                    encoder_resolution: float | None = None, q0: float | None = None,
                    tau: np.ndarray | None = None, torque_lag: float = 0.0,
                    encoder: str | None = None) -> Simulation:
    """Open-loop excitation of one joint with gravity compensated by the host, recorded at
    1/dt.  ``extra`` holds hidden physics (``bench.terms``); ``declared_inertia`` is the
    inertia written into the record's metadata (the truth by default); the joint feels the
    commanded torque ``torque_lag`` seconds late (the record keeps the command's times).
    A geared joint (backlash or a gear spring in ``extra``) is recorded by the encoder on
    ``encoder`` ("motor" or "load"; the spec's by default); ``true_q`` is what it reads."""
    n = int(round(duration / dt))
    t = np.arange(n) * dt
    recorded = sine_torque(amplitude, frequency, t) if tau is None else np.asarray(tau, float)
    # the held command, delayed: what the joint feels in each interval
    cmd = lagged(t, recorded, torque_lag)
    ev = terms.empty() if extra is None else terms.full(extra)
    f = spec.friction
    lo, hi = spec.position_limits
    start = 0.5 * (lo + hi) if q0 is None else q0
    side = spec.encoder if encoder is None else encoder
    if side not in ENCODER_SIDES:
        raise ValueError(f"encoder must be 'motor' or 'load', not {side!r}")
    gear = Gear.of(spec, ev, dt)
    if gear is None:
        n_sub = substeps_for(dt, spec.inertia, f.sigma0, f.sigma1, f.sigma2)
        q, v, _, *_ = simulate(cmd, dt, n_sub, spec.inertia, f.vector(), ev, start, 0.0, 0.0, 0.0)
    else:
        qm, vm, _, ql, vl, *_ = simulate_two_mass(
            cmd, dt, gear.n_sub, gear.M_motor, gear.M_load, f.vector(), ev, gear.gap, gear.w2,
            gear.c2, start, 0.0, 0.0, start, 0.0, 0.0)
        q, v = (ql, vl) if side == "load" else (qm, vm)
    rng = np.random.default_rng(seed)
    sigma_tau = spec.torque_noise if torque_noise is None else torque_noise
    res = spec.encoder_resolution if encoder_resolution is None else encoder_resolution
    tau_meas = recorded + sigma_tau * rng.standard_normal(n)
    meta = {
        "inertia": spec.inertia if declared_inertia is None else declared_inertia,
        "joint_type": spec.joint_type,
        "position_unit": spec.position_unit,
        "torque_unit": spec.torque_unit,
        "torque_hold": "zoh",
        "joint": spec.name,
        "source": "virtual",
        "seed": seed,
    }
    if gear is not None:
        meta["encoder"] = side
    rec = Record(t=t, tau=tau_meas, q=quantise(q, res), meta=meta)
    return Simulation(record=rec, true_q=q, true_v=v, true_friction_params=f, extra=ev)
