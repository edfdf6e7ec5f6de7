"""Physics the effect library does not have, for testing that the diagnosis never tells a wrong
story: a record with one of these must end "unexplained", with no library effect credited.

Each kind is a torque the joint feels on top of the commanded one, as a function of the
commanded torque and the joint's state, at magnitudes drawn from a seed relative to the
joint's own friction and excitation:

- ``saturating_torque_constant``: the motor's torque constant falls at high current, the joint
  feels tau (1 - k (tau / tau_max)^2) (k 0.1-0.2).  Under a sine it is a cubic of the phase, so a
  position series can pass for it.
- ``nonlinear_viscous``: viscous friction grows like |v|^beta (beta 0.4-0.6) instead of
  linearly, an extra term c ((|v| / v_ref)^beta - |v| / v_ref) sgn v that vanishes at 0 and at the
  reference speed (the sine test's top speed), peaking at 3-8 % of the friction at that speed.
- ``position_spring``: a cable carrier or a spring pulls the joint towards one end of its
  travel, k (q - q_0), 4-10 % of Fc at the ends (not periodic, not gravity's sine).
- ``load_dependent_friction``: a gear's tooth friction grows with the torque it carries (as in
  harmonic drives), an extra mu |tau| opposing the motion, 8-20 % of Fc at the sine's peak
  torque.  It is a friction level that follows the torque, not the speed or the position.
- ``local_defect``: the friction rises by 10-25 % of Fc over a short stretch of the travel (a
  dent in a raceway, a chip in the lubricant, a tight spot of a seal): a Gaussian bump of
  4-10 % of the travel in width, opposing the motion.  A function of position, but not
  periodic, so no position series describes it.

``excitation="two-tone"`` drives the joint as ``bench simulate --excitation two-tone`` does
(``virtual_drives.recording``), breaking the cycle lock of the single sine.

The joint is stepped one control period at a time (``VirtualJoint``), the extra torque held
over the period from its state at the start: these terms change slowly against 1 ms.
"""
from __future__ import annotations

import math

import numpy as np

from bench.records import Record
from virtual_drives.joint import JointSpec, VirtualJoint, quantise, sine_torque
from virtual_drives.recording import Recording, open_loop_torque
from virtual_drives.scenarios import travel_of

KINDS = ("saturating_torque_constant", "nonlinear_viscous", "position_spring",
         "load_dependent_friction", "local_defect")


def outside_record(spec: JointSpec, kind: str, seed: int, duration: float = 20.0,
                   dt: float = 1e-3, size: tuple[float, float] | None = None,
                   excitation: str = "sine") -> tuple[Record, str]:
    """A record of ``spec`` under its sine test (or two tones) with physics ``kind`` hidden.
    Returns the record and a description of what was hidden.  ``size`` (``nonlinear_viscous``
    only): the range its peak is drawn from, as a share of the friction at the reference speed."""
    rng = np.random.default_rng([seed, 29])
    A, f = spec.excitation
    n = int(round(duration / dt))
    t = np.arange(n) * dt
    cmd = (sine_torque(A, f, t) if excitation == "sine" else
           open_loop_torque(spec, Recording(excitation=excitation), t))
    Fc = spec.friction.Fc
    # without the preset's gravity, as the condition records (``virtual_drives.recording.make``):
    # with it a Pi-joint (j2, j4) hangs to one side and never slides upwards
    joint = VirtualJoint(spec, dt=dt, seed=seed, gravity=False)
    lo, hi = spec.position_limits
    mid = 0.5 * (lo + hi)
    travel = travel_of(spec, duration)
    v_ref = 2.0 * math.pi * f * 0.5 * travel          # the sine test's top speed, roughly
    if kind == "saturating_torque_constant":
        k = rng.uniform(0.1, 0.2)
        text = f"saturating torque constant, k = {k:.3f}"
        extra = lambda q, v, tau: -k * tau * (tau / A) ** 2  # noqa: E731
    elif kind == "nonlinear_viscous":
        beta = rng.uniform(0.4, 0.6)
        # a deviation from linear viscous friction, so sized against the friction at the
        # reference speed (Fc + sigma2 v_ref: 3 Fc on most joints, 21 Fc on the viscous-dominated
        # rotary motor, where a share of Fc alone would hide under the viscous level);
        # c (x^beta - x) peaks at x = beta^(1/(1-beta)) with c beta^(beta/(1-beta)) (1-beta)
        level = Fc + spec.friction.sigma2 * v_ref
        peak = rng.uniform(*(size or (0.03, 0.08))) * level
        c = peak / (beta ** (beta / (1.0 - beta)) * (1 - beta))
        text = f"viscous friction ~ |v|^{beta:.2f}, peak {peak / Fc:.2f} Fc"

        def extra(q, v, tau):
            x = abs(v) / v_ref
            return -c * (x ** beta - x) * math.copysign(1.0, v) if v != 0 else 0.0
    elif kind == "position_spring":
        k = rng.uniform(0.04, 0.10) * Fc / (0.5 * travel)
        q0 = mid + rng.uniform(-0.3, 0.3) * travel
        text = f"spring towards {q0:.4g}, {k:.4g} per unit of travel"
        extra = lambda q, v, tau: -k * (q - q0)  # noqa: E731
    elif kind == "load_dependent_friction":
        mu = rng.uniform(0.08, 0.20) * Fc / A
        text = f"friction rising with the carried torque, {mu * A / Fc:.2f} Fc at the peak torque"
        # sgn v smoothed over a speed at which the held term stays stable per period (its slope
        # mu A / v_c against the inertia) and far below the sliding speeds (1 % of v_ref)
        v_c = max(0.01 * v_ref, 2.0 * dt * mu * A / spec.inertia)
        extra = lambda q, v, tau: -mu * abs(tau) * math.tanh(v / v_c)  # noqa: E731
    elif kind == "local_defect":
        h = rng.uniform(0.10, 0.25) * Fc
        w = rng.uniform(0.04, 0.10) * travel
        q_d = joint.state.q + rng.uniform(-0.3, 0.3) * travel    # the motion is centred on the start
        text = f"a local friction defect, +{h / Fc:.2f} Fc at {q_d:.4g} over {w:.3g} (1 sigma)"
        v_c = 0.01 * v_ref                # sgn v smoothed far below the sliding speeds
        extra = lambda q, v, tau: -h * math.exp(-0.5 * ((q - q_d) / w) ** 2) * math.tanh(v / v_c)  # noqa: E731
    else:
        raise ValueError(f"unknown kind {kind!r}; known: {', '.join(KINDS)}")
    q = np.empty(n)
    for i in range(n):
        s = joint.state
        q[i] = s.q
        joint.advance(cmd[i] + extra(s.q, s.v, cmd[i]))
    tau = cmd + spec.torque_noise * joint.rng.standard_normal(n)
    meta = {"inertia": spec.inertia, "joint_type": spec.joint_type, "position_unit": spec.position_unit,
            "torque_unit": spec.torque_unit, "torque_hold": "zoh", "joint": spec.name,
            "source": "virtual", "seed": seed, "outside_library": text}
    return Record(t=t, tau=tau, q=quantise(q, spec.encoder_resolution), meta=meta), text
